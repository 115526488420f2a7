"""io stage of modal_twin."""
