"""models stage of modal_twin."""
