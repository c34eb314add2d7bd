"""What makes two measured runs the same: the run's identity and its digests.

A measured run's identity (:func:`measured_identity`: the code, the CPU
kernels, the spec's digest, ``quick``, the seeds and the settings) is what a
resumed run must match; the spec's digest (:func:`spec_digest`, of what the
spec says before its records are read, :func:`spec_fields`) and the records'
digests (:func:`record_digests`, read and checked before the run folder
changes) make a built-in benchmark named on the command line and its spec run
from Python one run.
"""

import hashlib

import skhybrid
from skhybrid.experiments._describe import canonical, describe
from skhybrid.experiments._settings import RunSettings
from skhybrid.experiments._spec import records_digest
from skhybrid.experiments.run._provenance import provenance

__all__ = ["measured_identity", "record_digests", "spec_digest", "spec_fields"]


def measured_identity(system, quick, seeds, *, digest=True, device="cpu"):
    """What makes two measured runs the same (a resumed run must match it).

    Parameters
    ----------
    system : MeasuredSystem
        The system, bound to its spec (:meth:`~MeasuredSystem.bind`).
    quick : bool
        Shorter fits.
    seeds : list of int
        The seeds.
    digest : bool, default=True
        Whether to take the spec's digest (False: ``"spec"`` is None, for a
        system not yet bound).
    device : {"cpu", "cuda"}, default="cpu"
        Where the networks train (part of the settings where not the CPU).

    Returns
    -------
    identity : dict
        The version and commit, the CPU kernels, the system (its spec's
        digest: a built-in benchmark named on the command line and its spec
        run from Python are one run), ``quick``, the seeds and the settings:
        a resume never reuses models fitted under another commit, other
        kernels or another spec.
    """
    settings = RunSettings(quick=bool(quick), seed=seeds[0], device=device)
    code = provenance()
    return {
        "skhybrid": skhybrid.__version__,
        "commit": code["commit"],
        "kernels": code["kernels"],
        "systems": [system.name],
        "spec": system.digest() if digest else None,
        "quick": bool(quick),
        "seeds": list(seeds),
        "settings": settings.to_dict(),
    }


def spec_fields(spec):
    """What a spec says of its system and candidates, without its records.

    Parameters
    ----------
    spec : SystemSpec
        The system.

    Returns
    -------
    fields : dict
        Name, ``n_init``, the physics and its inputs, the candidates and the
        notes, described without memory addresses.
    """
    return {
        "name": spec.name,
        "n_init": spec.n_init,
        "physics": describe(spec.physics),
        "physics_inputs": describe(spec.physics_inputs),
        "segments": describe(spec.segments),
        "hybrids": describe(spec.hybrids),
        "hybrid_records": spec.hybrid_records,
        "notes": spec.notes,
    }


def spec_digest(spec):
    """SHA-256 of what a spec says before its records are read.

    The physics, its inputs, the candidates, ``n_init``, ``dt`` and the notes,
    described without memory addresses (:func:`spec_fields` with the sample
    period and the physics' starts): the same spec gives the same digest in
    every session.

    Parameters
    ----------
    spec : SystemSpec
        The system.

    Returns
    -------
    digest : str
        Hex digest.
    """
    fields = {
        **spec_fields(spec),
        "dt": spec.dt,
        "physics_starts": describe(spec.physics_starts),
    }
    return hashlib.sha256(canonical(fields).encode()).hexdigest()


def record_digests(system, seeds, *, quick=False, data=None):
    """Read and check the estimation records; their SHA-256 under each seed's name.

    A run calls it before its folder changes: a bad record (or a test record
    given as data that does not fit them) is refused here, and a run carried on
    must find the records its finished models were fitted on
    (:meth:`~skhybrid.experiments.run._store.RunFolder.start`).

    Parameters
    ----------
    system : MeasuredSystem
        The system.
    seeds : list of int
        The run's seeds.
    quick : bool, default=False
        A built-in benchmark's quick form.
    data : str or Path or None, default=None
        A built-in benchmark's data folder; None fetches its files.

    Returns
    -------
    digests : dict of str to str
        ``{name of a seed's models in the folder: SHA-256 of the records}``.
    """
    bound = system.bind(data, quick)
    digest = records_digest(*bound.spec.estimation_records())
    return {bound.store_key(RunSettings(seed=seed)): digest for seed in seeds}
