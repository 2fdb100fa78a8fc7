"""The run-signing key rule: created atomically as 32 random bytes, mode 0600, owned by the user; any other key
is refused with the fix and never used (a forged run signed with a weak key is not trusted)."""

from __future__ import annotations

import json
import os
import stat
from pathlib import Path

import pytest

from vtrack_gym.agents.export import _run_signature, run_is_trusted, sign_run
from vtrack_gym.agents.trust_key import TrustKeyError, load_trust_key, trust_key_path
from vtrack_gym.cli import main


@pytest.fixture()
def config_home(tmp_path, monkeypatch) -> Path:
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "config"))
    return tmp_path / "config"


def _run_folder(tmp_path: Path) -> Path:
    run = tmp_path / "run"
    run.mkdir()
    (run / "config.json").write_text(json.dumps({"algo": "ppo", "env_id": "DLC120-v0"}))
    (run / "model.zip").write_bytes(b"a forged pickle")
    return run


def _forge(run: Path, key: bytes) -> None:
    """Sign ``run`` the way an attacker who knows (or guesses) ``key`` would."""
    (run / "vtrack-train.sig").write_text(_run_signature(run, key) + "\n")


def _write_key(text: str, mode: int = 0o600) -> Path:
    path = trust_key_path()
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    os.chmod(path, mode)
    return path


def test_new_key_is_32_random_bytes_mode_0600_owned_by_the_user(config_home):
    key = load_trust_key(create=True)
    st = os.stat(trust_key_path())
    assert key is not None and len(key) == 32
    assert stat.S_IMODE(st.st_mode) == 0o600 and st.st_uid == os.geteuid()
    assert load_trust_key(create=True) == key                 # kept, not replaced
    assert [p.name for p in trust_key_path().parent.iterdir()] == ["trust.key"]   # no temporary file left


@pytest.mark.parametrize(("content", "mode", "problem"), [
    ("", 0o600, "32 bytes"),                                   # what a full disk at first creation used to leave
    ("\n", 0o600, "32 bytes"),
    ("ab" * 16 + "\n", 0o600, "32 bytes"),                     # 16 bytes
    ("zz" * 32 + "\n", 0o600, "32 bytes"),                     # not hex
    ("ab" * 32 + "\n", 0o644, "mode 0644"),                    # readable by others
    ("ab" * 32 + "\n", 0o620, "mode 0620"),                    # writable by the group
])
def test_weak_key_is_refused_with_the_fix_and_a_forged_run_is_not_trusted(config_home, tmp_path, capsys,
                                                                         content, mode, problem):
    path = _write_key(content, mode)
    run = _run_folder(tmp_path)
    key = bytes.fromhex(content.strip()) if content.strip() and "z" not in content else b""
    _forge(run, key)
    with pytest.raises(TrustKeyError, match=problem):
        run_is_trusted(run)
    with pytest.raises(TrustKeyError, match="rm "):
        sign_run(run)                                          # never signs with it, never replaces it
    assert main(["export", "--run-dir", str(run), "--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err
    assert "trust key" in err and problem in err and not (tmp_path / "x.json").exists()
    assert path.read_text() == content


def test_key_of_another_owner_is_refused(config_home, tmp_path):
    if os.geteuid() != 0:
        pytest.skip("changing a file's owner needs root")
    path = _write_key("ab" * 32 + "\n")
    os.chown(path, 12345, -1)
    run = _run_folder(tmp_path)
    _forge(run, bytes.fromhex("ab" * 32))
    with pytest.raises(TrustKeyError, match="owned by user id 12345"):
        run_is_trusted(run)


def test_symlinked_key_is_refused(config_home, tmp_path):
    real = tmp_path / "elsewhere.key"
    real.write_text("ab" * 32 + "\n")
    os.chmod(real, 0o600)
    trust_key_path().parent.mkdir(parents=True)
    trust_key_path().symlink_to(real)
    with pytest.raises(TrustKeyError, match="symbolic link"):
        load_trust_key(create=False)


def test_key_creation_on_a_full_disk_leaves_nothing(config_home, monkeypatch):
    def full_disk(fd: int, data: bytes) -> int:
        raise OSError(28, "No space left on device")

    with monkeypatch.context() as patch:
        patch.setattr(os, "write", full_disk)
        with pytest.raises(TrustKeyError, match="No space left"):
            load_trust_key(create=True)
    assert not trust_key_path().exists() and list(trust_key_path().parent.iterdir()) == []


def test_a_valid_key_still_signs_and_verifies(config_home, tmp_path):
    run = _run_folder(tmp_path)
    sign_run(run)
    assert run_is_trusted(run)
    _forge(run, b"")                                           # a forger's guess
    assert not run_is_trusted(run)
