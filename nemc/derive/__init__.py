"""nemc.derive."""
