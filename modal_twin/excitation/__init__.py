"""excitation stage of modal_twin."""
