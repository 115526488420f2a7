"""diagnosis stage of modal_twin."""
