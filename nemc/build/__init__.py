"""The build stage: generated code -> a standalone package in the content-addressed cache
(builder.py: the key, the compiler, the cache's entries), and exported to the user's folder
without ever deleting what nemc did not write (export.py)."""
