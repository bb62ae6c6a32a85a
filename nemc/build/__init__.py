"""nemc.build."""
