"""The run: what every system's run goes through, whichever protocol it follows.

The run plan (its identity and seeds), the runner that fits a system's model zoo
through the written contract a system implements (``_contract``), the run
folder and its life cycle (store, lock, resume, transaction), progress,
provenance, worker processes, the report's common parts (HTML, console lines,
``write_report``) and :func:`run_system`. A change to how a run starts, resumes,
stores, shows progress or writes its report goes here; nothing here knows one
protocol's rules (those are in :mod:`~skhybrid.experiments.free_run` and
:mod:`~skhybrid.experiments.one_step`). Its public names are re-exported by
:mod:`skhybrid.experiments`.
"""
