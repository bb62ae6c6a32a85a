"""nemc.emit."""
