"""nemc.kinds."""
