"""The runtime: the real-time worker process, its supervisor, shared memory between them.

Imports the core only, and no middleware client library (checked by import-linter).
"""
