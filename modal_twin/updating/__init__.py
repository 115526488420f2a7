"""updating stage of modal_twin."""
