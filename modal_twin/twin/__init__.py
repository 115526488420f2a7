"""twin stage of modal_twin."""
