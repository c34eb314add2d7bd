"""The run folder: every finished model's scores and fitted model, kept as it lands.

A run writes into one folder (``skhybrid run --out DIR``)::

    DIR/
      .lock                      held while a run writes here (its pid inside)
      run.json                   the run: systems, seed, settings, command, status
      selection.json             a measured run's sealed selection and its hash,
                                 written before any test record is read
      models/SYSTEM/MODEL.joblib the fitted model (SYSTEM-seed-S for a measured
                                 system's seed S)
      models/SYSTEM/MODEL.*.joblib other fits kept with it (a measured physics'
                                 fit on the validation part)
      models/SYSTEM/MODEL.npz    its predictions on every test split
      models/SYSTEM/MODEL.json   its fit record, scores and the SHA-256 of each of its
                                 files (checked when loaded); written last, so a
                                 model is finished exactly when this file exists
      results.csv, results.json, report.html, *.png   once every model is finished

Every file is written to a temporary name and renamed into place, so an interrupt
leaves either the whole file or none of it. A run starts as a transaction: every
check (the folder's run, the records, the stored files) is made before anything
in the folder changes; a run replaced by ``--overwrite`` is moved aside and
deleted only once the new run has started.
"""

import hashlib
import json
import os
import pickle
import re
import shutil
import socket
import time
from functools import partial
from pathlib import Path

import numpy as np

__all__ = [
    "RUN_FORMAT",
    "SELECTION_FILE",
    "VALIDATION_RUNS",
    "FolderLock",
    "RunFolder",
    "RunFolderError",
]

#: Version of the folder's layout, recorded in ``run.json``.
RUN_FORMAT = 1

#: What a finished report leaves in the folder (besides the figures).
REPORT_FILES = ("results.csv", "results.json", "report.html", "selection.json")


#: The sealed selection's file in a run folder.
SELECTION_FILE = "selection.json"

#: Prefix of a measured model's stored out-of-fold free runs (``validation/K``
#: for fold K) among its predictions.
VALIDATION_RUNS = "validation/"


class RunFolderError(Exception):
    """The output folder cannot be used; the message says why and what to do."""


def _slug(text):
    return re.sub(r"[^a-z0-9]+", "-", text.lower()).strip("-")


def _write_atomic(path, write):
    """Call ``write(tmp_path)`` and rename the result to ``path``."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        write(tmp)
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def _sha256(path):
    with open(path, "rb") as f:
        return hashlib.file_digest(f, "sha256").hexdigest()


def _dump(estimator, path):
    """Pickle ``estimator`` to ``path`` with cloudpickle (``joblib.load`` reads it).

    cloudpickle stores the functions and classes defined in ``__main__`` (a
    script, a notebook) by value, as loky and Dask send them to their workers,
    and everything importable by reference, as pickle does: a physics written in
    the script that ran loads in a new session.
    """
    import cloudpickle

    with open(path, "wb") as f:
        cloudpickle.dump(estimator, f, protocol=pickle.HIGHEST_PROTOCOL)


#: Where a run replaced by ``--overwrite`` waits until the new run has started.
REPLACED = ".replaced"


def _pid_alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # someone else's process: it exists
        return True
    except OSError:
        return False
    return True


class FolderLock:
    """An exclusive lock on a folder: a ``.lock`` file holding the owner's pid.

    The file is created exclusively (``O_CREAT | O_EXCL``), so two runs cannot both
    take it. A lock whose process is gone (on this host) is stale: it is taken over.
    A lock held by a live process, or by another host, is refused.

    Parameters
    ----------
    folder : str or Path
        The folder to lock (it must exist).
    """

    NAME = ".lock"

    def __init__(self, folder):
        self.path = Path(folder) / self.NAME
        self.held = False
        self.stale_owner = None

    def _read(self):
        try:
            return json.loads(self.path.read_text())
        except (OSError, ValueError):
            return None

    def acquire(self):
        """Take the lock or raise :class:`RunFolderError` naming its holder."""
        record = {
            "pid": os.getpid(),
            "host": socket.gethostname(),
            "started": time.strftime("%Y-%m-%d %H:%M:%S"),
        }
        for _ in range(3):
            try:
                fd = os.open(self.path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
            except FileExistsError:
                owner = self._read()
                if owner is None:
                    # Being written by its owner this instant, or garbage: look again.
                    time.sleep(0.2)
                    owner = self._read()
                if owner is not None and (
                    owner.get("host") != record["host"] or _pid_alive(owner["pid"])
                ):
                    raise RunFolderError(
                        f"{self.path.parent} is in use by another skhybrid run "
                        f"(pid {owner.get('pid')} on {owner.get('host')}, started "
                        f"{owner.get('started')}); wait for it to finish or choose "
                        f"another --out (if that run is gone, delete {self.path})"
                    ) from None
                # Stale: its process is gone. Take it over.
                self.stale_owner = owner
                try:
                    self.path.unlink()
                except FileNotFoundError:
                    pass
                continue
            with os.fdopen(fd, "w") as f:
                json.dump(record, f)
            self.held = True
            return self
        raise RunFolderError(
            f"could not lock {self.path.parent}: another run keeps taking {self.path}"
        )

    def release(self):
        """Remove the lock file if this process holds it."""
        if self.held:
            owner = self._read()
            if owner is None or owner.get("pid") == os.getpid():
                try:
                    self.path.unlink()
                except FileNotFoundError:
                    pass
            self.held = False

    def __enter__(self):
        return self.acquire()

    def __exit__(self, *exc):
        self.release()


class RunFolder:
    """A run's output folder: checks, the run's identity, and finished models.

    Parameters
    ----------
    path : str or Path
        The folder.
    """

    def __init__(self, path):
        self.path = Path(path)
        self.lock = FolderLock(self.path)
        #: Whether :meth:`prepare` made the folder (see :meth:`remove_if_unused`).
        self.created = False

    # -- before any training ---------------------------------------------------------
    def prepare(self):
        """Create the folder and take its lock; raise :class:`RunFolderError`."""
        path = self.path
        if path.exists() and not path.is_dir():
            raise RunFolderError(f"--out {path} is a file, not a folder")
        try:
            self.created = not path.exists()
            path.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise RunFolderError(
                f"--out {path} cannot be created: {exc.strerror or exc}"
            ) from None
        try:
            self.lock.acquire()
        except RunFolderError:
            raise
        except OSError as exc:
            raise RunFolderError(
                f"--out {path} is not writable: {exc.strerror or exc}"
            ) from None
        try:  # the lock is written; so must the rest be
            _write_atomic(path / ".write-test", lambda p: p.write_text("ok"))
            (path / ".write-test").unlink()
        except OSError as exc:
            self.lock.release()
            raise RunFolderError(
                f"--out {path} is not writable: {exc.strerror or exc}"
            ) from None
        return self

    def remove_if_unused(self):
        """Remove the folder :meth:`prepare` made if nothing was written to it.

        A run refused after the folder was made (a spec that does not load, a
        Ctrl-C before training) leaves no empty folder behind; a folder that
        existed before, or holds anything, is kept.
        """
        if not self.created or self.lock.held:
            return
        try:
            self.path.rmdir()  # only an empty folder
        except OSError:
            pass

    def read_manifest(self):
        """The ``run.json`` of the run in the folder, or None."""
        try:
            return json.loads((self.path / "run.json").read_text())
        except FileNotFoundError:
            return None
        except (OSError, ValueError):
            return {"status": "unreadable"}

    def has_foreign_results(self):
        """Whether the folder holds a report or models no ``run.json`` describes."""
        return self._any_finished() or any(
            (self.path / name).exists() for name in REPORT_FILES
        )

    def start(self, identity, command, *, overwrite=False, resume=False, records=None):
        """Decide what happens to what the folder holds, and record the run.

        Every refusal comes before anything in the folder changes: the folder's
        run, the records the finished models were fitted on and the stored
        files' checksums are checked first; only then is a replaced run moved
        aside (see :meth:`discard_replaced`) and ``run.json`` written.

        Parameters
        ----------
        identity : dict
            What makes two runs the same (systems, seed, settings).
        command : str
            The command line, recorded for the resume hint.
        overwrite : bool, default=False
            Replace a previous run: its models and report are moved aside.
        resume : bool, default=False
            Also accept a finished run of the same identity (its report is
            written again from the stored models, with no training).
        records : dict of str to str or None, default=None
            ``{system: SHA-256 of its records}`` (a measured system's, for each
            seed's name in the folder): a run carried on must find the records
            its finished models were fitted on.

        Returns
        -------
        n_finished : int
            Models already finished in the folder (kept and skipped).

        Raises
        ------
        RunFolderError
            The folder holds a run this one must not touch, or fitted on other
            records, or a stored file is damaged; nothing was changed.
        """
        replace = self.check(identity, overwrite=overwrite, resume=resume)
        if not replace:
            for system, digest in (records or {}).items():
                self.check_records(system, digest, write=False)
            self.verify()
        if replace:
            self._set_aside()
        n_finished = self.n_finished()
        self.write_manifest(
            {
                "format": RUN_FORMAT,
                "status": "running",
                "command": command,
                "identity": identity,
            }
        )
        return n_finished

    def check(self, identity, *, overwrite=False, resume=False):
        """Whether the folder's run may be carried on or replaced; change nothing.

        Called by :meth:`start`, and before a run reads its records, so that a
        folder that must not be touched is refused first.

        Parameters
        ----------
        identity : dict
            What makes two runs the same (systems, seed, settings).
        overwrite : bool, default=False
            Replace a previous run.
        resume : bool, default=False
            Also accept a finished run of the same identity.

        Returns
        -------
        replace : bool
            Whether what the folder holds is replaced (set aside by
            :meth:`start`); False: it is carried on.

        Raises
        ------
        RunFolderError
            The folder holds a run this one must not touch.
        """
        if overwrite and resume:
            raise RunFolderError(
                "--overwrite replaces the run in the folder and --resume carries it "
                "on: pass one of them, not both"
            )
        manifest = self.read_manifest()
        replace = False
        if overwrite:
            replace = True
        elif manifest is None and self.has_foreign_results():
            raise RunFolderError(
                f"--out {self.path} already holds results (a report or models) "
                "that no run.json describes and this run would overwrite; pass "
                "--overwrite to replace them, or choose another --out"
            )
        elif manifest is not None and manifest.get("status") == "unreadable":
            raise RunFolderError(
                f"--out {self.path} holds a run whose run.json cannot be read; pass "
                "--overwrite to replace it, or choose another --out"
            )
        elif (
            manifest is not None
            and manifest.get("status") != "complete"
            and not self._any_finished()
        ):
            # A run that finished nothing: nothing to lose, start afresh.
            replace = True
        if not replace and manifest is not None:
            same = manifest.get("identity") == identity
            if manifest.get("status") == "complete" and not (same and resume):
                raise RunFolderError(
                    f"--out {self.path} already holds a finished run "
                    f"(`{manifest.get('command')}`); pass --overwrite to replace it"
                    + (", or --resume to write its report again" if same else "")
                    + ", or choose another --out"
                )
            if not same:
                raise RunFolderError(
                    f"--out {self.path} holds an unfinished run of other settings "
                    f"(`{manifest.get('command')}`); resume it with that command, "
                    "pass --overwrite to replace it, or choose another --out"
                )
        return replace

    def _set_aside(self):
        """Move what a previous run wrote into :data:`REPLACED` (not yet deleted)."""
        aside = self.path / REPLACED
        shutil.rmtree(aside, ignore_errors=True)  # a replaced run never deleted
        aside.mkdir()
        names = ["models", "cache", *REPORT_FILES, "run.json"]
        names += [png.name for png in self.path.glob("*.png")]
        for name in names:
            if (self.path / name).exists():
                os.replace(self.path / name, aside / name)

    def discard_replaced(self):
        """Delete the run ``start(overwrite=True)`` moved aside.

        Called once the new run has started cleanly (its spec checked, its
        records read): until then the replaced run is still in the folder.
        """
        shutil.rmtree(self.path / REPLACED, ignore_errors=True)

    def verify(self):
        """Check every finished model's files against their recorded SHA-256.

        Raises
        ------
        RunFolderError
            A file is missing or damaged; the message names it and the fix.
        """
        models = self.path / "models"
        if not models.is_dir():
            return
        for folder in sorted(d for d in models.iterdir() if d.is_dir()):
            for record in self.finished(folder.name).values():
                for name in record.get("sha256") or {}:
                    self._check_file(folder.name, record, name)

    def _check_file(self, system, record, name):
        """The path of a finished model's file, checked against its SHA-256."""
        folder = self._model_dir(system)
        path = folder / name
        expected = (record.get("sha256") or {}).get(name)
        problem = None
        if not path.is_file():
            problem = "is missing"
        elif expected is not None and _sha256(path) != expected:
            problem = (
                "is damaged: its SHA-256 differs from the one recorded when it was "
                "written"
            )
        if problem is not None:
            raise RunFolderError(
                f"{path} {problem} (model {record.get('model')!r}); rerun with "
                f"--overwrite (overwrite=True) to fit the run again, or delete "
                f"{folder / (_slug(record.get('model', '')) + '.json')} and rerun "
                "with --resume to fit that model alone again"
            )
        return path

    def n_finished(self):
        """Finished models in the folder, of every system and seed."""
        models = self.path / "models"
        if not models.is_dir():
            return 0
        return sum(len(self.finished(d.name)) for d in models.iterdir() if d.is_dir())

    def _any_finished(self):
        return any((self.path / "models").glob("*/*.json"))

    def write_manifest(self, manifest):
        text = json.dumps(manifest, indent=1)
        _write_atomic(self.path / "run.json", lambda p: p.write_text(text))

    def complete(self):
        """Mark the run finished (after its report is written)."""
        self.mark("complete")

    def mark(self, status, reason=None):
        """Record how the run ended in ``run.json``.

        Parameters
        ----------
        status : {"complete", "interrupted", "failed"}
            ``"interrupted"``: a Ctrl-C stopped it (finished models are kept
            and resumed); ``"failed"``: an error stopped it.
        reason : str or None, default=None
            What stopped it, recorded as ``"reason"``.
        """
        manifest = self.read_manifest() or {}
        if manifest.get("status") == "unreadable":
            return
        manifest["status"] = status
        if reason is not None:
            manifest["reason"] = reason
        else:
            manifest.pop("reason", None)
        self.write_manifest(manifest)

    def clear(self):
        """Remove what a previous run wrote: models, cache, report, run.json."""
        shutil.rmtree(self.path / "models", ignore_errors=True)
        shutil.rmtree(self.path / "cache", ignore_errors=True)
        for name in (*REPORT_FILES, "run.json"):
            (self.path / name).unlink(missing_ok=True)
        for png in self.path.glob("*.png"):
            png.unlink()

    # -- models ------------------------------------------------------------------
    def _model_dir(self, system):
        return self.path / "models" / _slug(system)

    def finished(self, system):
        """``{model name: record}`` of the finished models of ``system``."""
        folder = self._model_dir(system)
        out = {}
        if not folder.is_dir():
            return out
        for path in sorted(folder.glob("*.json")):
            try:
                record = json.loads(path.read_text())
            except (OSError, ValueError):
                continue  # a damaged record: that model runs again
            if (folder / record.get("predictions", "")).is_file():
                out[record["model"]] = record
        return out

    def load_predictions(self, system, record):
        """``{split: ndarray}`` of a finished model's predictions (checked)."""
        path = self._check_file(system, record, record["predictions"])
        with np.load(path) as data:
            return {split: data[split] for split in data.files}

    def load_estimator(self, system, record, extra=None):
        """A finished model's fitted estimator (or one of its extras), or None.

        Parameters
        ----------
        system : str
            The system's name.
        record : dict
            The model's record (from :meth:`finished`).
        extra : str or None, default=None
            The name of an extra estimator stored with it (``save_model``'s
            ``extras``); None loads the model itself.

        Returns
        -------
        estimator : object or None
            None where none was stored.

        Raises
        ------
        RunFolderError
            The file is missing, damaged (its SHA-256 differs from the record's)
            or cannot be loaded; the message names it and the fix.
        """
        import joblib

        name = (
            record.get("estimator")
            if extra is None
            else (record.get("extras") or {}).get(extra)
        )
        if name is None:
            return None
        path = self._check_file(system, record, name)
        try:
            with open(path, "rb") as f:
                return joblib.load(f)
        except (EOFError, ImportError, AttributeError, ValueError) as exc:
            # pickle.UnpicklingError is a ValueError's sibling: caught below.
            raise RunFolderError(
                f"{path} cannot be loaded ({type(exc).__name__}: {exc}); rerun with "
                "--overwrite (overwrite=True) to fit the run again"
            ) from exc
        except pickle.UnpicklingError as exc:
            raise RunFolderError(
                f"{path} cannot be loaded ({exc}); rerun with --overwrite "
                "(overwrite=True) to fit the run again"
            ) from exc

    def save_arrays(self, system, name, arrays):
        """Write named arrays beside a system's models (``<name>.npz``).

        Parameters
        ----------
        system : str
            The system's (and seed's) name in the folder.
        name : str
            The file's stem.
        arrays : dict of str to ndarray
            What to write.
        """
        folder = self._model_dir(system)
        folder.mkdir(parents=True, exist_ok=True)

        def save(p):
            with open(p, "wb") as f:
                np.savez(f, **arrays)

        _write_atomic(folder / f"{_slug(name)}.npz", save)

    def check_records(self, system, digest, write=True):
        """Refuse to carry on a run whose records changed; record them otherwise.

        Parameters
        ----------
        system : str
            The system's (and seed's) name in the folder.
        digest : str
            SHA-256 of the records the run fits
            (:func:`~skhybrid.experiments._spec.records_digest`).
        write : bool, default=True
            Record ``digest`` where none is checked; False only checks.

        Raises
        ------
        RunFolderError
            The folder's finished models were fitted on other records.
        """
        folder = self._model_dir(system)
        path = folder / "records.sha256"
        if path.is_file() and self.finished(system):
            if path.read_text().strip() != digest:
                raise RunFolderError(
                    f"--out {self.path} holds models of {system} fitted on other "
                    "records (their SHA-256 differs); pass --overwrite to refit them "
                    "on these records, or choose another --out"
                )
            return
        if not write:
            return
        folder.mkdir(parents=True, exist_ok=True)
        _write_atomic(path, lambda p: p.write_text(digest + "\n"))

    def save_model(self, system, name, estimator, predictions, record, extras=None):
        """Write one finished model: fitted estimator, predictions, then record.

        Parameters
        ----------
        system : str
            The system's name.
        name : str
            The model's name in the zoo.
        estimator : estimator or None
            The fitted model (pickled with cloudpickle, read with
            ``joblib.load``); None writes no pickle.
        predictions : dict of str to ndarray
            Predictions on each test split.
        record : dict
            Fit record and scores (JSON-serialisable); ``model``, ``predictions``,
            ``estimator`` and ``extras`` keys are added.
        extras : dict of str to estimator or None, default=None
            Other fitted estimators kept with the model (a measured physics'
            fit on the validation part, which later models start from).
        """
        folder = self._model_dir(system)
        folder.mkdir(parents=True, exist_ok=True)
        stem = _slug(name)
        record = dict(record, model=name, predictions=f"{stem}.npz")
        checksums = {}
        if estimator is not None:
            _write_atomic(folder / f"{stem}.joblib", partial(_dump, estimator))
            record["estimator"] = f"{stem}.joblib"
            checksums[f"{stem}.joblib"] = _sha256(folder / f"{stem}.joblib")
        for key, extra in (extras or {}).items():
            if extra is None:
                continue
            file = f"{stem}.{_slug(key)}.joblib"

            _write_atomic(folder / file, partial(_dump, extra))
            record.setdefault("extras", {})[key] = file
            checksums[file] = _sha256(folder / file)

        def save(p):
            with open(p, "wb") as f:
                np.savez(f, **predictions)

        _write_atomic(folder / f"{stem}.npz", save)
        checksums[f"{stem}.npz"] = _sha256(folder / f"{stem}.npz")
        # Checked on load and on resume: a damaged file is named, not unpickled.
        record["sha256"] = checksums
        text = json.dumps(record, indent=1)
        _write_atomic(folder / f"{stem}.json", lambda p: p.write_text(text))
