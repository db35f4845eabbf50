"""A trained policy played again: in MJX, in Gymnasium, or recorded, and ``python -m jaxpg.evaluate``."""
