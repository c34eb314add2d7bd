"""The run folder's life cycle, in one place: :class:`RunTransaction`.

``skhybrid run`` and :func:`~skhybrid.experiments.run_system` both run a plan
inside it: the folder is checked and locked, the run started (or resumed) once
every refusal has had its chance, and ``run.json`` records how it ended:
``"complete"``, ``"interrupted"`` (Ctrl-C) or ``"failed"`` (an error). The lock
is released however it ends, and a folder the run made but never wrote to is
removed.
"""

from skhybrid.experiments.run._store import RunFolder

__all__ = ["RunTransaction"]


class RunTransaction:
    """A run folder's life cycle: prepare, start or resume, then how it ended.

    Used as a context manager: entering checks and locks the folder
    (:class:`~skhybrid.experiments.RunFolderError` where it cannot be used);
    :meth:`start` checks the run against the folder and starts it;
    :meth:`finish` writes the report and marks the run complete. An exception
    leaving the block marks a started run ``"interrupted"`` (a
    :class:`KeyboardInterrupt`) or ``"failed"`` (any other); on the way out the
    lock is released and a folder made for nothing is removed.

    Parameters
    ----------
    out : str or Path
        The run folder.

    Attributes
    ----------
    folder : RunFolder
        The folder (its ``path``, and where the plan's fit writes its models).
    started : bool
        Whether :meth:`start` wrote the folder's ``run.json`` for this run.
    n_models : int or None
        Models the started run fits (None before :meth:`start`).

    Examples
    --------
    >>> from skhybrid.experiments import RunTransaction  # doctest: +SKIP
    >>> with RunTransaction("runs/mine") as run:  # doctest: +SKIP
    ...     run.start(plan, "my command")
    ...     run.finish(plan.fit(run.folder), "my command")
    """

    def __init__(self, out):
        self.folder = RunFolder(out)
        self.started = False
        self.n_models = None
        self._ended = False

    def __enter__(self):
        try:
            self.folder.prepare()
        except BaseException:
            # A Ctrl-C while the lock was being taken: no lock or empty folder
            # left behind (a refusal holds no lock).
            self._close()
            raise
        return self

    def __exit__(self, exc_type, exc, tb):
        try:
            if exc_type is not None and issubclass(exc_type, KeyboardInterrupt):
                self.interrupted()
            elif exc_type is not None:
                self.failed(f"{exc_type.__name__}: {exc}")
        finally:
            self._close()
        return False

    def _close(self):
        self.folder.lock.release()
        self.folder.remove_if_unused()

    def start(self, plan, command, *, overwrite=False, resume=False):
        """Check ``plan`` against the folder, then start (or resume) it there.

        Every refusal comes before the folder changes: the folder's run (its
        identity), then the records (read and checked), then what the folder
        holds of them. Once started, a run this one replaces is deleted.

        Parameters
        ----------
        plan : RunPlan
            What the run fits.
        command : str
            The command recorded in ``run.json`` and the report.
        overwrite : bool, default=False
            Replace a run already in the folder.
        resume : bool, default=False
            Also carry on a finished run of the same identity.

        Returns
        -------
        n_finished : int
            Models already finished in the folder (a resumed run's).

        Raises
        ------
        RunFolderError
            The folder cannot take this run; nothing in it was changed.
        ValueError or OSError
            A system's records are missing or bad (read before the folder
            changes).
        """
        try:
            identity = plan.identity  # a built-in benchmark reads its files here
        except (ValueError, OSError):
            # A folder holding a run of other settings is refused first.
            self._refuse_other_settings(plan, overwrite=overwrite, resume=resume)
            raise
        self.folder.check(identity, overwrite=overwrite, resume=resume)
        records = plan.record_digests()
        self.n_models = plan.n_models
        n_finished = self.folder.start(
            identity, command, overwrite=overwrite, resume=resume, records=records
        )
        self.started = True
        # The new run has started cleanly: the run it replaces can go.
        self.folder.discard_replaced()
        return n_finished

    def _refuse_other_settings(self, plan, *, overwrite, resume):
        """Refuse the folder's run where its settings alone differ from ``plan``'s."""
        known = plan.settings_identity()
        manifest = self.folder.read_manifest() or {}
        theirs = manifest.get("identity") or {}
        if {k: theirs.get(k) for k in known} != known:
            self.folder.check(known, overwrite=overwrite, resume=resume)

    def n_finished(self):
        """Models finished in the folder so far.

        Returns
        -------
        n_finished : int
            Of every system and seed.
        """
        return self.folder.n_finished()

    def finish(self, results, command, *, wall_time=None):
        """Write the report of a finished run and mark it complete.

        Parameters
        ----------
        results : list of ExperimentResult or MeasuredRun
            What the plan's fit returned.
        command : str
            The command the report names.
        wall_time : float or None, default=None
            Seconds for the whole run, printed in the report.

        Returns
        -------
        paths : dict of str to Path
            The report's files (:func:`~skhybrid.experiments.write_report`).
        """
        from skhybrid.experiments.run._report import write_report

        paths = write_report(
            results, self.folder.path, command=command, wall_time=wall_time
        )
        self.folder.complete()
        self._ended = True
        return paths

    def interrupted(self):
        """Record a Ctrl-C: ``run.json`` says how many models were finished.

        Returns
        -------
        n_finished : int
            Models finished and kept in the folder (a resume skips them).
        """
        done = self.n_finished()
        if self.started and not self._ended:
            self.folder.mark(
                "interrupted", f"Ctrl-C after {done} of {self.n_models} models"
            )
            self._ended = True
        return done

    def failed(self, reason):
        """Record in ``run.json`` that an error stopped the started run.

        Parameters
        ----------
        reason : str
            What stopped it (``run.json``'s ``"reason"``).
        """
        if self.started and not self._ended:
            self.folder.mark("failed", reason)
            self._ended = True
