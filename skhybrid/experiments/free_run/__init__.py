"""The free-run protocol: measured records, a searched family, a sealed test.

A measured system (a user's machine or a built-in benchmark): its candidate
family (``_family``: physics, NARX, corrections, state-space hybrids, the
stack), the search of each candidate by blocked cross-validation of the
estimation records (``_search``, ``_stack``), the seeds (``_seeds``: searched at
the first, refitted at each), the seal written before any test record is read
(``_seal``), the free runs of the test records and their scores
(``_test_runs``, ``_scoring``), and its report (``_report``, ``_verdicts``). A
change to the measured family, to how it is chosen or to how a measured run is
scored goes here.
"""
