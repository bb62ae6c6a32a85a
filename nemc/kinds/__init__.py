"""The kinds: every joint, load and constraint kind, one class in one module of its registry
(joints/, loads/, constraints/, each with its table), answering every question the pipeline asks
of it. Below them what they build on: terms.py (symbols, locations, points), spatial.py (planar
spatial algebra), contract.py (the protocols through which a kind reads its YAML, sees bodies
and joints, and says what it does to them). The front end reads the kinds; the derivation asks
them; nothing else names a kind."""
