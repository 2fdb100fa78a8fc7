"""Property-based fuzzing of ``vtrack_gym.cli.main``: random and invalid argument lists never give a traceback.

Accepted outcomes: argparse usage errors (``SystemExit(2)``), ``--help`` (``SystemExit(0)``), a return code of 0,
or a return code of 2 with a message on stderr. Anything else (an exception escaping ``main``) is a traceback for
the user. Episodes are cut to 5 steps and the figure writers are stubbed so every example stays fast; env
creation, policy construction, reset, metrics and the store are the real code.
"""

from __future__ import annotations

import io
import itertools
import shlex
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from vtrack_gym.cli import main

ENV_IDS = ["DLC120-v0", "LateralTracking-v0", "LateralTrackingRandom-v0"]
POLICIES = ["smc", "mpc", "lqr", "stanley", "pure_pursuit", "mpc_osqp"]
_counter = itertools.count()


@pytest.fixture(scope="module")
def cli_sandbox(tmp_path_factory):
    """cwd in a temp dir (default store and figure folders land there), short episodes, no matplotlib."""
    import vtrack_gym.evaluation.figures.plots as plots
    import vtrack_gym.evaluation.rollouts.episode_score as bench  # where an episode's rollout is run
    from vtrack_gym.evaluation.rollouts.rollout import rollout as real_rollout

    root = tmp_path_factory.mktemp("cli_fuzz")
    (root / "garbage_dir").mkdir()
    (root / "agent.json").write_text("{}")
    with pytest.MonkeyPatch.context() as mp:
        mp.chdir(root)
        mp.setattr(bench, "rollout", lambda policy, env, seed=0, options=None, **kw: real_rollout(
            policy, env, seed=seed, options=options, max_steps=5))
        for name in ("plot_trajectories", "plot_signals"):
            mp.setattr(plots, name, lambda *a, **kw: Path(str(a[-1])))
        mp.setattr(plots, "plot_deviation_rates", lambda *a, **kw: Path(str(a[-1])))
        yield root


def run_cli(argv: list[str]) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        try:
            rc = main(argv)
        except SystemExit as exc:  # argparse: usage error (2) or --help (0)
            rc = exc.code
    return rc, out.getvalue(), err.getvalue()


def _check(argv: list[str]) -> tuple[int, str, str]:
    rc, out, err = run_cli(argv)  # an exception escaping main() fails the test here: that is a traceback
    assert rc in (0, 2), (argv, rc, err)
    assert "Traceback" not in err and "Traceback" not in out
    if rc == 2:
        assert err.strip(), f"exit code 2 without a message on stderr: {argv}"
    return rc, out, err


# --------------------------------------------------------------------------------------------- strategies
junk = st.one_of(
    st.text(max_size=8).filter(lambda t: t.strip() != "tune"),  # never start a GA run
    st.sampled_from(["", " ", "-", "--", "---x", "--store=", "-vv", "\x00", "ü", "../../etc/passwd", "%s", "{}",
                     "$(id)", ";ls"]),
)
policy_names = st.one_of(st.sampled_from([*POLICIES, "nope", "SMC", "../../etc/passwd", "agent.json", "garbage_dir",
                                          "x.pkl", "x.npz", "x.zip"]), st.text(min_size=1, max_size=6))
policy_lists = st.lists(st.sampled_from([*POLICIES, "nope", ""]), min_size=1, max_size=3).map(",".join).filter(
    lambda s: any(s.split(",")))
seeds = st.one_of(st.lists(st.integers(0, 2**40), min_size=1, max_size=2).map(lambda v: ",".join(map(str, v))),
                  st.sampled_from(["x", "1.5", "0,,1", "1e3", "0x1", " ", "١"]))


@st.composite
def argv_lists(draw) -> list[str]:
    command = draw(st.sampled_from(["benchmark", "eval", "leaderboard", "plot", "bogus", ""]))
    store = draw(st.sampled_from(["shared.sqlite", f"store_{next(_counter)}.sqlite"]))
    argv = [*draw(st.sampled_from([[], ["-v"], ["--verbose"]])), command] if command else []
    options: dict[str, st.SearchStrategy] = {
        "benchmark": {"--suite": st.sampled_from(["paper", "robust", "nope"]), "--policies": policy_lists,
                      "--figures": st.just("figs"), "--no-figures": st.none(), "--quick": st.none(),
                      "--store": st.just(store), "--format": st.sampled_from(["md", "csv", "json", "xml"])},
        "eval": {"--policy": policy_names, "--env": st.sampled_from(ENV_IDS),
                 "--preset": st.sampled_from(["default", "paper", "tuned", "nope"]), "--seeds": seeds,
                 "--store": st.just(store)},
        "leaderboard": {"--suite": st.sampled_from(["paper", "robust", "custom", "x"]), "--store": st.just(store),
                        "--format": st.sampled_from(["md", "csv", "json", "yaml"])},
        "plot": {"--policies": policy_lists, "--env": st.sampled_from(ENV_IDS), "--out": st.just("figs")},
    }.get(command, {})
    if command == "eval" and draw(st.integers(0, 3)) > 0:  # mostly complete, valid eval commands
        argv += ["--env", draw(st.sampled_from(ENV_IDS)), "--policy", draw(st.sampled_from(POLICIES))]
        options.pop("--env")
        options.pop("--policy")
    if command == "benchmark":  # keep benchmark runs small: one or two policies
        argv += ["--policies", draw(st.sampled_from(["smc", "stanley,lqr", "nope"])), "--quick"]
        options.pop("--policies")
    for flag in draw(st.lists(st.sampled_from(sorted(options)), unique=True)) if options else []:
        value = draw(options[flag])
        argv += [flag] if value is None else [flag, value]
    if draw(st.integers(0, 4)) == 0:
        argv.insert(draw(st.integers(0, len(argv))), draw(junk))
    if draw(st.integers(0, 9)) == 0:
        argv.append(draw(st.sampled_from(["-h", "--help"])))
    return argv


# --------------------------------------------------------------------------------------------- tests
@settings(max_examples=60, deadline=None, database=None, suppress_health_check=[HealthCheck.too_slow])
@given(argv=argv_lists())
def test_cli_fuzzed_argv_never_tracebacks(cli_sandbox, argv):
    rc, _, _ = _check(argv)
    command = next((a for a in argv if a in ("benchmark", "eval", "leaderboard", "plot")), "other")
    event(f"rc={rc} {command}")


@settings(max_examples=60, deadline=None, database=None)
@given(argv=st.lists(junk, max_size=5))
def test_cli_random_tokens_never_traceback(cli_sandbox, argv):
    _check(argv)


@pytest.mark.parametrize("args", [
    "",
    "bogus",
    "eval",
    "eval --policy smc",
    "eval --env DLC120-v0",
    "benchmark --suite nope",
    "leaderboard --format xml",
    "--store x leaderboard",
])
def test_cli_usage_errors_exit_2(cli_sandbox, args):
    rc, _, err = _check(shlex.split(args))
    assert rc == 2 and "usage:" in err


@pytest.mark.parametrize(("args", "message"), [
    ("eval --policy nope --env DLC120-v0 --store s1.sqlite", "unknown policy 'nope'"),
    ("eval --policy smc --env DLC120-v0 --preset nope --store s1.sqlite", "preset 'nope'"),
    ("eval --policy smc --env DLC120-v0 --seeds x --store s1.sqlite", "--seeds must be"),
    ("eval --policy /etc/passwd --env DLC120-v0 --store s1.sqlite", "looks like an agent file"),
    ("eval --policy ../../etc/passwd --env DLC120-v0 --store s1.sqlite", "unknown policy"),
    ("eval --policy smc --env CartPole-v1 --store s1.sqlite", "design_model"),
    ("benchmark --policies nope --no-figures --store s1.sqlite", "unknown policy 'nope'"),
    ("leaderboard --store missing.sqlite", "run `vtrack benchmark` first"),
])
def test_cli_own_errors_return_2_with_message(cli_sandbox, args, message):
    rc, _, err = _check(shlex.split(args))
    assert rc == 2 and message in err




@pytest.mark.parametrize("args", [
    pytest.param("leaderboard --store agent.json", id="store_not_sqlite"),
    pytest.param("benchmark --policies smc --no-figures --store agent.json", id="benchmark_store_not_sqlite"),
    pytest.param("leaderboard --store garbage_dir", id="store_is_directory"),
    pytest.param("eval --policy smc --env Nope-v0 --store s2.sqlite", id="unknown_env"),
    pytest.param("eval --policy smc --env ../../etc/passwd --store s2.sqlite", id="malformed_env"),
    pytest.param("eval --policy smc --env DLC120-v0 --seeds -1 --store s2.sqlite", id="negative_seed"),
    pytest.param("plot --policies , --env DLC120-v0 --out figs", id="plot_no_policy"),
    pytest.param("plot --policies smc --env Nope-v0 --out figs", id="plot_unknown_env"),
])
def test_cli_known_tracebacks(cli_sandbox, args):
    rc, _, err = _check(shlex.split(args))
    assert rc == 2 and "error" in err
