"""The demo: every capability run on built-in simulated data, written as one report.

`kinsync.demo.run.run_demo` runs the sections in order, each in its own module
(`budget`, `method_a`, `clock`, `georef`, `ins`, `method_b`, `end_to_end`,
`validation`, `calibration`): simulate with known truth (`kinsync.sim`), estimate with the library,
and present with `kinsync.report` (figures, tables, the HTML report).
"""
