"""nemc.tools."""
