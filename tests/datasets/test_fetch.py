"""The fetchers, offline: the benchmark files served from localhost.

A local HTTP server serves the files of ``../shared/data`` as the official
sources publish them (zipped where the official download is an archive); the
fetchers are pointed at it with ``mirror=``. Checked: download and load, reuse of
the cache without a request, a corrupted cached file (hash mismatch: downloaded
again), a corrupted download (refused, named), and no network (an error naming
the URL, the files and the folder to put them in). The friction damper, published
file by file, is served as a tree: one request per file.
"""

import threading
import zipfile
from functools import partial
from http.server import SimpleHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

import numpy as np
import pytest

from skhybrid.datasets import (
    fetch_cascaded_tanks,
    fetch_coupled_electric_drives,
    fetch_emps,
    fetch_friction_damper,
    fetch_silverbox,
    fetch_wiener_hammerstein,
    get_data_home,
    load_cascaded_tanks,
    load_coupled_electric_drives,
    load_emps,
    load_friction_damper,
    load_silverbox,
    load_wiener_hammerstein,
)

DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data"
pytestmark = pytest.mark.skipif(
    not DATA.is_dir(), reason=f"the benchmark data folder {DATA} is absent"
)

#: (fetcher, loader, folder in shared/data, archive name or None: the files as
#: they are, subfolders included)
CASES = {
    "silverbox": (fetch_silverbox, load_silverbox, "silverbox", "SilverboxFiles.zip"),
    "emps": (fetch_emps, load_emps, "emps", "EMPS.zip"),
    "cascaded_tanks": (
        fetch_cascaded_tanks,
        load_cascaded_tanks,
        "cascaded_tanks",
        "CascadedTanksFiles.zip",
    ),
    "coupled_electric_drives": (
        fetch_coupled_electric_drives,
        load_coupled_electric_drives,
        "coupled_electric_drives",
        "FULLTEXT01.zip",
    ),
    "wiener_hammerstein": (
        fetch_wiener_hammerstein,
        load_wiener_hammerstein,
        "wiener_hammerstein",
        None,
    ),
    "friction_damper": (
        fetch_friction_damper,
        load_friction_damper,
        "friction_damper_backlash",
        None,
    ),
}
#: Requests a first fetch makes, where not 1 (a benchmark published file by file).
REQUESTS = {"friction_damper": 9}


class _Counting(SimpleHTTPRequestHandler):
    requests = []

    def do_GET(self):
        type(self).requests.append(self.path)
        super().do_GET()

    def log_message(self, *args):
        pass


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    """Serve the official archives and files from a folder on localhost."""
    root = tmp_path_factory.mktemp("served")
    for _, _, folder, archive in CASES.values():
        if archive is None:
            for path in sorted((DATA / folder).rglob("*")):
                if path.is_file():
                    target = root / path.relative_to(DATA / folder)
                    target.parent.mkdir(parents=True, exist_ok=True)
                    target.write_bytes(path.read_bytes())
            continue
        files = sorted(p for p in (DATA / folder).iterdir() if p.is_file())
        inner = archive.removesuffix(".zip")
        with zipfile.ZipFile(root / archive, "w") as zipped:
            for path in files:
                zipped.write(path, f"{inner}/{path.name}")
    handler = partial(_Counting, directory=str(root))
    httpd = ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{httpd.server_address[1]}", root
    httpd.shutdown()
    httpd.server_close()


def _same(a, b):
    assert a.keys() == b.keys()
    for key in a:
        if isinstance(a[key], np.ndarray):
            np.testing.assert_array_equal(a[key], b[key])
        elif hasattr(a[key], "keys"):
            _same(a[key], b[key])
        else:
            assert a[key] == b[key], key


@pytest.mark.parametrize("name", list(CASES))
def test_fetch_downloads_checks_and_loads_then_reuses_the_cache(name, server, tmp_path):
    url, _ = server
    fetch, load, folder, _ = CASES[name]
    _Counting.requests.clear()
    n_requests = REQUESTS.get(name, 1)
    data = fetch(tmp_path, mirror=url)
    assert len(_Counting.requests) == n_requests
    _same(data, load(DATA / folder))
    again = fetch(tmp_path, mirror=url)
    assert len(_Counting.requests) == n_requests  # read from the cache, no request
    _same(again, data)


def test_a_corrupted_cached_file_is_downloaded_again(server, tmp_path):
    url, _ = server
    fetch_emps(tmp_path, mirror=url)
    cached = tmp_path / "emps" / "DATA_EMPS.mat"
    cached.write_bytes(b"not the file")
    _Counting.requests.clear()
    data = fetch_emps(tmp_path, mirror=url)
    assert len(_Counting.requests) == 1
    _same(data, load_emps(DATA / "emps"))


def test_a_corrupted_download_is_refused_and_named(server, tmp_path):
    url, root = server
    mirror = tmp_path / "bad"
    mirror.mkdir()
    original = root / "WienerHammerBenchMark.mat"
    bad = root / "bad"
    bad.mkdir(exist_ok=True)
    (bad / "WienerHammerBenchMark.mat").write_bytes(original.read_bytes()[:-10])
    with pytest.raises(OSError, match=r"WienerHammerBenchMark\.mat") as info:
        fetch_wiener_hammerstein(tmp_path / "home", mirror=f"{url}/bad")
    assert "SHA256" in str(info.value) or "hash" in str(info.value).lower()
    assert not (tmp_path / "home" / "wiener_hammerstein" / original.name).exists()


def test_without_network_the_error_says_where_to_put_the_files(tmp_path):
    import socket

    with socket.socket() as s:  # a port nothing listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    with pytest.raises(OSError) as info:
        fetch_silverbox(tmp_path, mirror=f"http://127.0.0.1:{port}")
    message = str(info.value)
    assert f"http://127.0.0.1:{port}/SilverboxFiles.zip" in message
    assert "SNLS80mV.mat" in message and "Schroeder80mV.mat" in message
    assert str(tmp_path / "silverbox") in message
    assert "drive.google.com" in message or "docs.google.com" in message


def test_the_mirror_can_come_from_the_environment(server, tmp_path, monkeypatch):
    url, _ = server
    monkeypatch.setenv("SKHYBRID_DATA_MIRROR", url)
    monkeypatch.setenv("SKHYBRID_DATA", str(tmp_path / "from-env"))
    assert get_data_home() == tmp_path / "from-env"
    data = fetch_cascaded_tanks()
    assert (tmp_path / "from-env" / "cascaded_tanks" / "dataBenchmark.mat").is_file()
    _same(data, load_cascaded_tanks(DATA / "cascaded_tanks"))


def test_data_home_rejects_a_non_path():
    with pytest.raises(TypeError, match=r"data_home must be a str or pathlib\.Path"):
        get_data_home(3)


FRICTION = "friction_damper_backlash"


def test_friction_damper_files_come_one_by_one_under_their_paths(server, tmp_path):
    url, _ = server
    _Counting.requests.clear()
    data = fetch_friction_damper(tmp_path, mirror=url)
    assert sorted(_Counting.requests) == sorted(
        f"/{p.relative_to(DATA / FRICTION).as_posix()}"
        for p in (DATA / FRICTION).rglob("*.json")
    )
    assert (tmp_path / FRICTION / "earthquake_profiles" / "KocaeliDBE.json").is_file()
    assert data.license == "CC BY-SA 4.0"


def test_a_corrupted_cached_friction_damper_file_alone_is_downloaded_again(
    server, tmp_path
):
    url, _ = server
    fetch_friction_damper(tmp_path, mirror=url)
    cached = tmp_path / FRICTION / "earthquake_profiles" / "KocaeliDBE.json"
    cached.write_bytes(cached.read_bytes()[:-10])
    _Counting.requests.clear()
    data = fetch_friction_damper(tmp_path, mirror=url)
    assert _Counting.requests == ["/earthquake_profiles/KocaeliDBE.json"]
    assert (
        cached.read_bytes()
        == (DATA / FRICTION / "earthquake_profiles" / "KocaeliDBE.json").read_bytes()
    )
    _same(data, load_friction_damper(DATA))


def test_a_corrupted_friction_damper_download_is_refused_and_named(server, tmp_path):
    url, root = server
    bad = root / "bad-friction"
    for path in (root / "characterization_datasets").iterdir():
        target = bad / "characterization_datasets" / path.name
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_bytes(path.read_bytes())
    (bad / "earthquake_profiles").mkdir(exist_ok=True)
    (bad / "earthquake_profiles" / "ImperialValleyDBE.json").write_bytes(b"{}")
    with pytest.raises(OSError, match=r"ImperialValleyDBE\.json") as info:
        fetch_friction_damper(tmp_path / "home", mirror=f"{url}/bad-friction")
    message = str(info.value)
    assert "SHA256" in message or "hash" in message.lower()
    folder = tmp_path / "home" / FRICTION
    assert not (folder / "earthquake_profiles" / "ImperialValleyDBE.json").exists()
    # The files that hashed right stay: a later fetch asks for the rest only.
    assert (
        folder / "characterization_datasets" / "1Hz30lbtension1amplitude.json"
    ).is_file()


def test_without_network_the_friction_damper_error_names_url_file_and_folder(tmp_path):
    import socket

    with socket.socket() as s:  # a port nothing listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    with pytest.raises(OSError) as info:
        fetch_friction_damper(tmp_path, mirror=f"http://127.0.0.1:{port}/")
    message = str(info.value)
    first = "characterization_datasets/0.5Hz30lbtension0.5amplitude.json"
    assert f"http://127.0.0.1:{port}/{first}" in message
    assert str(tmp_path / FRICTION) in message
    # Every file, with its official URL (the source's folder names hold spaces).
    official = (
        "https://raw.githubusercontent.com/ARTS-Laboratory/"
        "Dataset-Friction-Damper-with-Backlash/"
        "0e09aa9d950760277e31c08cd93fd01f39a5af09/data/dataset-2/"
    )
    assert f"{official}earthquake%20profiles/KocaeliDBE.json" in message
    assert f"{official}characterization%20datasets/2Hz30lbtension0.5amplitude.json" in (
        message
    )
    assert "earthquake_profiles/ImperialValleyDBE.json" in message


def test_an_offline_friction_damper_fetch_says_what_to_do_first(tmp_path):
    import socket

    with socket.socket() as s:  # a port nothing listens on: no network
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    with pytest.raises(OSError) as info:
        fetch_friction_damper(tmp_path, mirror=f"http://127.0.0.1:{port}")
    first, *files, why = str(info.value).splitlines()
    folder = tmp_path / FRICTION
    assert len(first) < 400 and "127.0.0.1" not in first
    assert str(folder) in first and "load_friction_damper" in first
    expected = sorted(
        p.relative_to(DATA / FRICTION).as_posix()
        for p in (DATA / FRICTION).rglob("*.json")
    )
    assert f"download its {len(expected)} missing files below" in first
    assert sorted(line.split()[0] for line in files) == expected
    assert why.startswith("Why the download failed:") and "127.0.0.1" in why
