"""Session videos given as fsspec URLs (ergopose.remote): local copies made once, checked, removed;
one-line errors for URLs that cannot be read; a session whose settings name its videos by URL."""

from __future__ import annotations

import shutil
import uuid

import pytest

fsspec = pytest.importorskip("fsspec")

from ergopose import cli, remote  # noqa: E402
from ergopose.errors import InputError  # noqa: E402
from ergopose.session import load_session  # noqa: E402


@pytest.fixture
def cache(tmp_path, monkeypatch):
    folder = tmp_path / "cache"
    monkeypatch.setenv(remote.CACHE_ENV, str(folder))
    return folder


@pytest.fixture
def memory_video():
    """A file of 3 MB + 5 bytes (more than one copy block is not needed: the size check is what
    matters) in fsspec's in-memory filesystem; its URL."""
    url = f"memory://bucket-{uuid.uuid4().hex}/day1/cam_1.mp4"
    data = bytes(range(256)) * (3 * 4096) + b"tail!"
    with fsspec.open(url, "wb") as f:
        f.write(data)
    yield url, data
    fsspec.filesystem("memory").rm(url.split("://", 1)[1].split("/", 1)[0], recursive=True)


def test_urls_and_paths():
    assert remote.is_url("s3://bucket/day1/cam_1.mp4") and remote.is_url("file:///mnt/ergo/cam_1.mp4")
    assert remote.is_url("memory://x/y.mp4")
    for path in ("cam_1.mp4", "videos/cam_1.mp4", "/mnt/ergo/cam_1.mp4", "C:\\videos\\cam_1.mp4", "C:/v.mp4"):
        assert not remote.is_url(path), path


def test_a_copy_is_made_once_with_the_remote_bytes_and_forgotten(cache, memory_video):
    url, data = memory_video
    path = remote.fetch(url)
    assert path.read_bytes() == data
    assert path == remote.cached_path(url, len(data)) and cache in path.parents and path.name == "cam_1.mp4"
    inode = path.stat().st_ino
    assert remote.fetch(url, size=len(data)) == path and path.stat().st_ino == inode  # reused, not copied again
    assert not [p for p in cache.rglob("*.part")]
    assert remote.forget([path, cache.parent / "elsewhere.mp4"]) == 1
    assert not path.exists() and not path.parent.exists()


def test_a_copy_of_another_size_is_replaced(cache, memory_video):
    url, data = memory_video
    dest = cache / "given" / "cam.mp4"
    dest.parent.mkdir(parents=True)
    dest.write_bytes(b"short")
    assert remote.fetch(url, dest).read_bytes() == data


def test_a_video_changed_since_the_client_saw_it_is_refused(cache, memory_video):
    url, data = memory_video
    with pytest.raises(InputError, match="changed during the run") as err:
        remote.fetch(url, size=len(data) - 1)
    assert str(err.value).startswith(url)


@pytest.mark.parametrize(
    "url,words",
    [
        ("memory://no-such-bucket/cam_1.mp4", "video file not found"),
        ("file:///no/such/folder/cam_1.mp4", "video file not found"),
        ("nosuchprotocol://host/cam_1.mp4", "cannot open this URL"),
    ],
)
def test_an_unreadable_url_is_one_line_naming_it(cache, url, words):
    with pytest.raises(InputError) as err:
        remote.fetch(url)
    text = str(err.value)
    assert text.startswith(f"{url}: ") and words in text and "\n" not in text
    assert not cache.exists() or not any(cache.rglob("*"))


@pytest.fixture(scope="module")
def simulated(tmp_path_factory):
    from ergopose.sim.writer import SimulationConfig, simulate_session

    path = tmp_path_factory.mktemp("sim") / "day1"
    simulate_session(path, SimulationConfig(workers=2, minutes=0.02, seed=2))
    return path


def with_url_videos(session, dst, videos_dir):
    """A copy of ``session`` whose settings name its videos by file:// URL (moved to videos_dir)."""
    shutil.copytree(session, dst)
    videos_dir.mkdir(parents=True)
    text = (dst / "settings.toml").read_text()
    for video in sorted(dst.glob("cam_*.mp4")):
        shutil.move(video, videos_dir / video.name)
        old = f'video = "{video.name}"'
        assert old in text
        text = text.replace(old, f'video = "{(videos_dir / video.name).as_uri()}"')
    (dst / "settings.toml").write_text(text)
    return dst


@pytest.mark.slow
def test_a_session_reads_its_videos_from_urls(simulated, tmp_path, cache):
    session = with_url_videos(simulated, tmp_path / "day1", tmp_path / "store")
    local = load_session(simulated)
    s = load_session(session)
    assert [c.video_url for c in s.cameras] == [
        (tmp_path / "store" / c.video_path.name).as_uri() for c in local.cameras
    ]
    assert all(cache in c.video_path.parents for c in s.cameras)
    assert s.frame_count == local.frame_count and s.fps == local.fps
    for a, b in zip(s.cameras, local.cameras):
        assert a.video_path.read_bytes() == b.video_path.read_bytes()
    assert all(c.video_url is None for c in local.cameras)


@pytest.mark.slow
def test_a_session_with_a_missing_url_video_stops_with_one_line(simulated, tmp_path, cache, capsys):
    session = with_url_videos(simulated, tmp_path / "day1", tmp_path / "store")
    (tmp_path / "store" / "cam_2.mp4").unlink()
    assert cli.main(["assess", "--session", str(session), "--out", str(tmp_path / "out")]) == 2
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("ergopose: error:")]
    assert err == [f"ergopose: error: {(tmp_path / 'store' / 'cam_2.mp4').as_uri()}: video file not found"]
