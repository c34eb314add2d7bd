"""Fetchers of the measured benchmark data: download once, check, load.

Each ``fetch_*`` downloads the official file or archive of a benchmark once into
a data home (:func:`get_data_home`), keeps the files a loader reads under
``<data_home>/<folder>/``, checks the SHA256 of every one of them, and returns
what the matching ``load_*`` loader returns. Later calls read the cached files
and touch no network; a file whose hash does not match is downloaded again.
The downloading itself is :mod:`pooch`'s.
"""

import hashlib
import os
import shutil
import tempfile
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from urllib.parse import quote

__all__ = [
    "fetch_cascaded_tanks",
    "fetch_coupled_electric_drives",
    "fetch_emps",
    "fetch_friction_damper",
    "fetch_silverbox",
    "fetch_wiener_hammerstein",
    "get_data_home",
]

#: Environment variable naming the data home.
DATA_HOME_ENV = "SKHYBRID_DATA"
#: Environment variable naming a mirror: a base URL serving the official files
#: and archives under their official names (a benchmark published file by file:
#: each file under its path relative to the benchmark's folder).
MIRROR_ENV = "SKHYBRID_DATA_MIRROR"


@dataclass(frozen=True)
class BenchmarkFiles:
    """Where a benchmark's files come from and what they must hash to.

    Parameters
    ----------
    folder : str
        Subfolder of the data home (the one its loader looks in).
    url : str
        The official download: an archive holding the files, or the one file,
        or (with ``sources``) the base URL the files are published under.
    archive : str or None
        The archive's official name; None when ``url`` is the file itself or a
        base URL.
    sha256 : dict of str to str
        The files a loader reads, by name (a path relative to ``folder``), and
        their SHA256.
    citation : str
        What to cite when using the data.
    extra_urls : tuple of str
        Other official locations of the same archive, tried in order.
    sources : dict of str to str
        For a benchmark published file by file: each file's official path
        relative to ``url``, by name; empty otherwise. A mirror serves each file
        under its name instead.
    """

    folder: str
    url: str
    archive: object
    sha256: dict
    citation: str
    extra_urls: tuple = field(default=())
    sources: dict = field(default_factory=dict)


def _google_drive(file_id):
    return f"https://docs.google.com/uc?export=download&id={file_id}"


#: The friction damper's files (``data/dataset-2/`` of its source) and their SHA256.
_FRICTION_DAMPER_SHA256 = {
    "characterization_datasets/0.5Hz30lbtension0.5amplitude.json": (
        "7ded96e7236317bcdc574182473967c5c072e687c7d7b5e0b694bcf93a4eb7f9"
    ),
    "characterization_datasets/0.5Hz30lbtension1.5amplitude.json": (
        "eafbe3a53eab301ae3fe15ea9ec2889a03373ad27add94ef39d7b1acc96b8149"
    ),
    "characterization_datasets/0.5Hz30lbtension1amplitude.json": (
        "3d58d0f71296a6221974c14454352fa29a27d536295fd5cb05e6d946a7cf30db"
    ),
    "characterization_datasets/1Hz30lbtension0.5amplitude.json": (
        "8d8c46dcbed3889ae8dbe6ff3698d67e6453349ab728a8915b22680453c4d277"
    ),
    "characterization_datasets/1Hz30lbtension1.5amplitude.json": (
        "1a894d5857486ee56f363343c3216d2fb300c2fc8777439cca8ee2d02a7dd35c"
    ),
    "characterization_datasets/1Hz30lbtension1amplitude.json": (
        "ed02a98a96369937851bed92b4e5e92e34d98ceebd4db81d5bd65d5b77c4bc91"
    ),
    "characterization_datasets/2Hz30lbtension0.5amplitude.json": (
        "68ed9bd269da97845b4b94534a3ed48651022490cf337dacd2eaaf4abb2df2ed"
    ),
    "earthquake_profiles/ImperialValleyDBE.json": (
        "9060242d42c480e2657494f43372392f1ef478310ab7039281bfa9f219d12d26"
    ),
    "earthquake_profiles/KocaeliDBE.json": (
        "31f407c2ee09cb69ffe685d3c43bfddbc34eb340fd761216d36e57c78f5aba40"
    ),
}


#: The official sources of the benchmarks (those of the ``nonlinear-benchmarks``
#: loader, v1.0.1) and the SHA256 of every file the loaders read.
BENCHMARK_FILES = {
    "silverbox": BenchmarkFiles(
        folder="silverbox",
        url=_google_drive("17iS-6oBUUgrmiAcrZoG9S5sOaljZnDSy"),
        archive="SilverboxFiles.zip",
        sha256={
            "SNLS80mV.mat": (
                "5c7413a52255af0cb4e2f93fb6903beb92b08965ba1e6ad0a6ffedfed8477ed4"
            ),
            "Schroeder80mV.mat": (
                "ec5a9740a4789aa20b9d84f387424c0218e843844807b30b367c218778339fb6"
            ),
        },
        citation="T. Wigren, J. Schoukens, ECC 2013, pp. 2933-2938.",
    ),
    "emps": BenchmarkFiles(
        folder="emps",
        url=_google_drive("1zwoXYa9-3f8NQ0ohzmjpF7UxbNgRTHkS"),
        archive="EMPS.zip",
        sha256={
            "DATA_EMPS.mat": (
                "6cf6814ae14618795da0101aae2bb97ff0c6351b0501b5492751b02b07facf7e"
            ),
            "DATA_EMPS_PULSES.mat": (
                "0eab75bb1f6b16228ee78791343a88bf9bfd9a51036ac9807d7b5fc11c0e1704"
            ),
        },
        citation="A. Janot, M. Gautier, M. Brunot, Workshop on Nonlinear System "
        "Identification Benchmarks, Eindhoven, 2019.",
    ),
    "cascaded_tanks": BenchmarkFiles(
        folder="cascaded_tanks",
        url="https://data.4tu.nl/file/d4810b78-6cdd-48fe-8950-9bd601e5f47f/"
        "3b697e42-01a4-4979-a370-813a456c36f5",
        archive="CascadedTanksFiles.zip",
        sha256={
            "dataBenchmark.mat": (
                "cb2f88d4388be4d3f2a24c6402fba804976aac5f2e1f26cda59ea0a38d016eab"
            ),
        },
        citation="M. Schoukens, P. Mattsson, T. Wigren, J.P. Noel, Workshop on "
        "Nonlinear System Identification Benchmarks, Brussels, 2016.",
        extra_urls=(_google_drive("1HnQf_gu0g_UlggoBqy2s34l9YJiFdN01"),),
    ),
    "coupled_electric_drives": BenchmarkFiles(
        folder="coupled_electric_drives",
        url="https://uu.diva-portal.org/smash/get/diva2:1165531/FULLTEXT01.zip",
        archive="FULLTEXT01.zip",
        sha256={
            "DATAUNIF.MAT": (
                "102c8d8012d6e850d50c13227b8c2280fe69f8bc4a845177f8bc3d761d152c89"
            ),
            "DATAPRBS.MAT": (
                "47d0825678d854d8a1bbcfb0ad1188026b853f69beb2067ea00cfd88d13dc4ca"
            ),
        },
        citation="T. Wigren, M. Schoukens, Tech. Rep. 2017-024, Uppsala "
        "University, 2017.",
    ),
    "wiener_hammerstein": BenchmarkFiles(
        folder="wiener_hammerstein",
        url="http://www.ee.kth.se/~hjalmars/ifac_tc11_benchmarks/"
        "2009_wienerhammerstein/WienerHammerBenchMark.mat",
        archive=None,
        sha256={
            "WienerHammerBenchMark.mat": (
                "096e6128687efb664d146d28fc17db4c5a94f247c4b3a2e451319be1efb25ae2"
            ),
        },
        citation="J. Schoukens, J. Suykens, L. Ljung, 15th IFAC SYSID, 2009.",
    ),
    "friction_damper": BenchmarkFiles(
        folder="friction_damper_backlash",
        url="https://raw.githubusercontent.com/ARTS-Laboratory/"
        "Dataset-Friction-Damper-with-Backlash/"
        "0e09aa9d950760277e31c08cd93fd01f39a5af09/data/dataset-2",
        archive=None,
        sha256=_FRICTION_DAMPER_SHA256,
        citation="D. Coble, P. Huggins, L. Cao, J. Ricles, A. Downey, "
        '"Dataset-Friction-Damper-with-Backlash", GitHub, 2022 (CC BY-SA 4.0).',
        # The source's folder names hold spaces where ours hold underscores.
        sources={name: name.replace("_", " ", 1) for name in _FRICTION_DAMPER_SHA256},
    ),
}


def get_data_home(data_home=None):
    """The folder the fetchers keep their files in, created if missing.

    Parameters
    ----------
    data_home : str or pathlib.Path or None, default=None
        The folder; None reads the ``SKHYBRID_DATA`` environment variable, and
        without it uses ``~/skhybrid_data``.

    Returns
    -------
    data_home : pathlib.Path
        The folder (``~`` expanded).

    Examples
    --------
    >>> from skhybrid.datasets import get_data_home
    >>> get_data_home("/tmp/skhybrid-data").name
    'skhybrid-data'
    """
    if data_home is None:
        data_home = os.environ.get(DATA_HOME_ENV, Path("~") / "skhybrid_data")
    if not isinstance(data_home, (str, os.PathLike)):
        raise TypeError(
            "data_home must be a str or pathlib.Path naming a folder; got "
            f"{type(data_home).__name__} {data_home!r}."
        )
    folder = Path(data_home).expanduser()
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def _sha256(path):
    with open(path, "rb") as handle:
        return hashlib.file_digest(handle, "sha256").hexdigest()


def _valid(folder, spec):
    """The files of ``spec`` in ``folder`` whose hash is wrong or that are missing."""
    bad = []
    for name, expected in spec.sha256.items():
        path = folder / name
        if not path.is_file() or _sha256(path) != expected:
            bad.append(name)
    return bad


def _mirror(mirror):
    return mirror if mirror is not None else os.environ.get(MIRROR_ENV)


def _urls(spec, mirror):
    mirror = _mirror(mirror)
    if mirror and spec.sources:
        return [str(mirror).rstrip("/")]  # the base; each file under its name
    if mirror:
        name = spec.archive or next(iter(spec.sha256))
        return [f"{str(mirror).rstrip('/')}/{name}"]
    return [spec.url, *spec.extra_urls]


def _file_url(spec, base, name, mirrored):
    """The URL of one file of a benchmark published file by file."""
    path = name if mirrored else spec.sources[name]
    return f"{base}/{quote(path)}"


def _download_files(spec, base, folder, mirrored):
    """Download the missing or corrupt files of ``spec`` one by one from ``base``.

    Stops at the first failure, raising OSError naming that file's URL.
    """
    for name in _valid(folder, spec):
        url = _file_url(spec, base, name, mirrored)
        target = folder / name
        target.parent.mkdir(parents=True, exist_ok=True)
        try:
            _download(url, target, known_hash=f"sha256:{spec.sha256[name]}")
        except Exception as exc:  # re-raised with the URL of the file
            raise OSError(f"{url} ({name}): {type(exc).__name__}: {exc}") from exc


def _download(url, target, known_hash=None):
    import pooch

    logger = pooch.get_logger()
    level = logger.level
    logger.setLevel("WARNING")  # errors are ours to report, in one message
    try:
        return Path(
            pooch.retrieve(
                url,
                known_hash=known_hash,
                fname=target.name,
                path=target.parent,
                progressbar=False,
            )
        )
    finally:
        logger.setLevel(level)


def _extract(archive, folder, names):
    """Copy the members named ``names`` (at any depth) of a zip into ``folder``."""
    try:
        with zipfile.ZipFile(archive) as zipped:
            members = {Path(m).name: m for m in zipped.namelist()}
            for name in names:
                if name not in members:
                    raise OSError(
                        f"the archive {archive.name} holds no {name} (it holds "
                        f"{sorted(members)[:8]})."
                    )
                with (
                    zipped.open(members[name]) as src,
                    open(folder / name, "wb") as dst,
                ):
                    shutil.copyfileobj(src, dst)
    except zipfile.BadZipFile as exc:
        raise OSError(
            f"the download {archive.name} is not a zip archive: {exc}"
        ) from exc


def _fetch(key, data_home, mirror):
    spec = BENCHMARK_FILES[key]
    home = get_data_home(data_home)
    folder = home / spec.folder
    folder.mkdir(parents=True, exist_ok=True)
    missing = _valid(folder, spec)
    if not missing:
        return home
    for name in missing:
        (folder / name).unlink(missing_ok=True)
    errors = []
    for url in _urls(spec, mirror):
        try:
            if spec.sources:
                _download_files(spec, url, folder, bool(_mirror(mirror)))
            elif spec.archive is None:
                (name,) = spec.sha256
                _download(url, folder / name, known_hash=f"sha256:{spec.sha256[name]}")
            else:
                with tempfile.TemporaryDirectory(dir=home) as tmp:
                    archive = _download(url, Path(tmp) / spec.archive)
                    _extract(archive, folder, list(spec.sha256))
        except Exception as exc:  # noqa: BLE001 - reported with every URL tried
            if spec.sources:
                errors.append(str(exc))  # names the file's URL
            else:
                errors.append(f"{url}: {type(exc).__name__}: {exc}")
            continue
        still = _valid(folder, spec)
        if not still:
            return home
        errors.append(f"{url}: SHA256 mismatch of {still} after download")
        for name in still:
            (folder / name).unlink(missing_ok=True)
    if spec.sources:
        missing = _valid(folder, spec)
        # What to do first, on one line; then one line per file and the reason.
        files = "\n".join(
            f"  {name}  <-  {_file_url(spec, spec.url, name, False)}"
            for name in missing
        )
        more = f" (and {len(errors) - 1} more)" if len(errors) > 1 else ""
        raise OSError(
            f"could not fetch the {key} benchmark (no connection?): download its "
            f"{len(missing)} missing files below into {folder} under their names "
            "(subfolders included), or pass the folder holding them to "
            f"skhybrid.datasets.load_{key} (or `skhybrid run --data`).\n"
            f"{files}\nWhy the download failed: {errors[0] if errors else '?'}"
            f"{more}"
        )
    files = ", ".join(spec.sha256)
    source = spec.archive or next(iter(spec.sha256))
    raise OSError(
        f"could not fetch the {key} benchmark. Download {source} from "
        f"{spec.url} yourself and put "
        + (f"the files {files} from it" if spec.archive else "it")
        + f" into {folder} (or pass the folder holding them to "
        f"skhybrid.datasets.load_{key}, or to `skhybrid run --data`). "
        f"Why the download failed: {'; '.join(errors)}"
    )


def fetch_silverbox(data_home=None, *, mirror=None):
    """Download (once), check and load the Silverbox benchmark.

    Parameters
    ----------
    data_home : str or pathlib.Path or None, default=None
        Where the files are kept (see :func:`get_data_home`).
    mirror : str or None, default=None
        Base URL of a mirror serving the official archive under its official
        name (``SilverboxFiles.zip``); None uses the ``SKHYBRID_DATA_MIRROR``
        environment variable, else the official source.

    Returns
    -------
    data : sklearn.utils.Bunch
        What :func:`load_silverbox` returns.

    Raises
    ------
    OSError
        When the files cannot be downloaded or do not hash as expected; the
        message names the URL, the files and the folder to put them in.
    """
    from skhybrid.datasets._loaders import load_silverbox

    return load_silverbox(_fetch("silverbox", data_home, mirror))


def fetch_emps(data_home=None, *, mirror=None):
    """Download (once), check and load the EMPS benchmark.

    Parameters
    ----------
    data_home : str or pathlib.Path or None, default=None
        Where the files are kept (see :func:`get_data_home`).
    mirror : str or None, default=None
        Base URL of a mirror serving ``EMPS.zip``; None uses the
        ``SKHYBRID_DATA_MIRROR`` environment variable, else the official source.

    Returns
    -------
    data : sklearn.utils.Bunch
        What :func:`load_emps` returns.

    Raises
    ------
    OSError
        When the files cannot be downloaded or do not hash as expected.
    """
    from skhybrid.datasets._loaders import load_emps

    return load_emps(_fetch("emps", data_home, mirror))


def fetch_cascaded_tanks(data_home=None, *, mirror=None):
    """Download (once), check and load the Cascaded Tanks benchmark.

    Parameters
    ----------
    data_home : str or pathlib.Path or None, default=None
        Where the files are kept (see :func:`get_data_home`).
    mirror : str or None, default=None
        Base URL of a mirror serving ``CascadedTanksFiles.zip``; None uses the
        ``SKHYBRID_DATA_MIRROR`` environment variable, else the official source.

    Returns
    -------
    data : sklearn.utils.Bunch
        What :func:`load_cascaded_tanks` returns.

    Raises
    ------
    OSError
        When the files cannot be downloaded or do not hash as expected.
    """
    from skhybrid.datasets._loaders import load_cascaded_tanks

    return load_cascaded_tanks(_fetch("cascaded_tanks", data_home, mirror))


def fetch_coupled_electric_drives(data_home=None, *, mirror=None):
    """Download (once), check and load the Coupled Electric Drives benchmark.

    Parameters
    ----------
    data_home : str or pathlib.Path or None, default=None
        Where the files are kept (see :func:`get_data_home`).
    mirror : str or None, default=None
        Base URL of a mirror serving ``FULLTEXT01.zip`` (the report's archive);
        None uses the ``SKHYBRID_DATA_MIRROR`` environment variable, else the
        official source.

    Returns
    -------
    data : sklearn.utils.Bunch
        What :func:`load_coupled_electric_drives` returns.

    Raises
    ------
    OSError
        When the files cannot be downloaded or do not hash as expected.
    """
    from skhybrid.datasets._loaders import load_coupled_electric_drives

    return load_coupled_electric_drives(
        _fetch("coupled_electric_drives", data_home, mirror)
    )


def fetch_wiener_hammerstein(data_home=None, *, mirror=None):
    """Download (once), check and load the Wiener-Hammerstein benchmark.

    Parameters
    ----------
    data_home : str or pathlib.Path or None, default=None
        Where the files are kept (see :func:`get_data_home`).
    mirror : str or None, default=None
        Base URL of a mirror serving ``WienerHammerBenchMark.mat``; None uses
        the ``SKHYBRID_DATA_MIRROR`` environment variable, else the official
        source.

    Returns
    -------
    data : sklearn.utils.Bunch
        What :func:`load_wiener_hammerstein` returns.

    Raises
    ------
    OSError
        When the file cannot be downloaded or does not hash as expected.
    """
    from skhybrid.datasets._loaders import load_wiener_hammerstein

    return load_wiener_hammerstein(_fetch("wiener_hammerstein", data_home, mirror))


def fetch_friction_damper(data_home=None, *, mirror=None):
    """Download (once), check and load the friction damper with backlash.

    The nine files of :func:`load_friction_damper` are downloaded one by one
    from the source's GitHub repository
    (ARTS-Laboratory/Dataset-Friction-Damper-with-Backlash at commit
    0e09aa9d950760277e31c08cd93fd01f39a5af09, ``data/dataset-2/``). The data
    are licensed under CC BY-SA 4.0: cite D. Coble, P. Huggins, L. Cao, J.
    Ricles, A. Downey, "Dataset-Friction-Damper-with-Backlash", GitHub, 2022.

    Parameters
    ----------
    data_home : str or pathlib.Path or None, default=None
        Where the files are kept (see :func:`get_data_home`), under
        ``friction_damper_backlash/``.
    mirror : str or None, default=None
        Base URL of a mirror serving each file under its path relative to
        ``friction_damper_backlash/`` (for example
        ``<mirror>/earthquake_profiles/KocaeliDBE.json``); None uses the
        ``SKHYBRID_DATA_MIRROR`` environment variable, else the official source.

    Returns
    -------
    data : sklearn.utils.Bunch
        What :func:`load_friction_damper` returns.

    Raises
    ------
    OSError
        When a file cannot be downloaded or does not hash as expected; the
        message names its URL, the file and the folder to put it in.
    """
    from skhybrid.datasets._loaders import load_friction_damper

    return load_friction_damper(_fetch("friction_damper", data_home, mirror))
