"""The core: components, ports, parameters, logging, graph and order, executor, clocks.

Everything a component author and a test on a simulated clock need. Imports nothing
else of rtcf and no middleware (checked by import-linter, see docs/architecture.md).
"""
