"""rig stage of modal_twin."""
