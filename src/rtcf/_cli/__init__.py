"""The ``rtcf`` command line, its reports and plots, and the introspection commands.

The top layer: may import every other layer; nothing imports it.
"""
