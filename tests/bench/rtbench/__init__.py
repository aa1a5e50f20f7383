"""rtbench -- the parts of tests/bench/run_bench.py (irpd's wake-up latency against cyclictest's),
one module a concern: the reference, each measured scenario, the report.  run_bench.py is the
command; it calls them in order.
"""
