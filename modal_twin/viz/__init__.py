"""viz stage of modal_twin."""
