"""The session vectors (spec/vectors/sessions), one module per group of sessions.

tools/gen_session_vectors.py writes them (`make generate`) and checks them (`--check`);
`common` holds the building blocks every session module uses.
"""
