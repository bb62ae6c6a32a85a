"""The front end: a mechanism file -> the validated Mechanism (mechanism.py), a plain value every
later stage takes. Reading it bounded (reading.py), YAML with a line and column on every node
(parse.py), expressions by a whitelist grammar, never evaluated (expr.py), every rule of the
format checked with FILE:LINE: key.path messages, all problems collected before refusing
(validate.py), parameter and constant values resolved (values.py). The kinds read their own
YAML keys through the Reader the front end offers them (nemc/kinds/contract.py)."""
