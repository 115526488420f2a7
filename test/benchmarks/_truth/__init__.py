"""Independent truth simulator of the hidden-effect benchmark (own laws and integration;
only the linear structure is read from the library)."""
