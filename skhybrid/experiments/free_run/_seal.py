"""The seal: every seed's selection frozen and hashed before any test record.

:func:`seal` writes ``selection.json``: the spec's description
(:func:`describe_spec`), every candidate's validation RMSE, every choice and the
chosen model of each seed, with the SHA-256 of all of it. Only then are the
test records read (:func:`~skhybrid.experiments.free_run._seeds.run_seeds`).
The report prints the hash beside the test figures, so a reader can check that
the figures come from the selection the file records, made before the test was
seen.
"""

import hashlib
import json

from skhybrid.experiments._describe import canonical
from skhybrid.experiments._spec import records_digest
from skhybrid.experiments.free_run._identity import spec_fields
from skhybrid.experiments.run._provenance import provenance
from skhybrid.experiments.run._store import SELECTION_FILE, _write_atomic

__all__ = ["describe_spec", "seal"]


def describe_spec(spec, U, Y=None):
    """What of a spec the selection depends on, as JSON-ready data.

    Parameters
    ----------
    spec : SystemSpec
        The system.
    U : list of ndarray
        Its estimation records' inputs (their lengths are recorded).
    Y : list of ndarray or None, default=None
        Their outputs; with them, the records' SHA-256 is recorded too.

    Returns
    -------
    description : dict
        Name, sample period, ``n_init``, record lengths, the physics, the
        candidate family and the notes.
    """
    return {
        **spec_fields(spec),
        "dt": spec.sample_period(),
        "record_lengths": [len(u) for u in U],
        "records_sha256": None if Y is None else records_digest(U, Y),
    }


def seal(results, folder_path):
    """Write the frozen selection of every seed and its hash; return both.

    Parameters
    ----------
    results : list of MeasuredResult
        One per seed, every model fitted and chosen; no test record read.
    folder_path : Path or None
        The run folder (``selection.json`` goes there); None writes nothing.

    Returns
    -------
    sealed : dict
        ``sha256`` and ``selection`` (what was hashed).
    """
    system = results[0].system
    selection = {
        "system": describe_spec(system.spec, *results[0].train),
        "seeds": [r.selection() for r in results],
        # The code and CPU kernels the selection was made with.
        "provenance": provenance(),
    }
    digest = hashlib.sha256(canonical(selection).encode()).hexdigest()
    sealed = {"sha256": digest, "selection": selection}
    if folder_path is not None:
        text = json.dumps(
            {"sha256": digest, "hashed": "canonical JSON of 'selection'", **sealed},
            indent=1,
            default=str,
        )
        _write_atomic(folder_path / SELECTION_FILE, lambda p: p.write_text(text))
    return sealed
