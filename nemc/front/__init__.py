"""nemc.front."""
