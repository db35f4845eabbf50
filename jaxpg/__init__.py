"""jaxpg: JAX-native policy-gradient training on MuJoCo MJX."""

__version__ = "0.1.0"
