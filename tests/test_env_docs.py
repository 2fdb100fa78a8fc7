"""Every registered id has its documentation page (generated from the registry by ``vtrack_gym.envs.env_docs``),
with a description and a version history, so a scenario added without docs fails here."""

from __future__ import annotations

import vtrack_gym
from vtrack_gym.envs.env_docs import (
    DEPRECATED_PAGES,
    DESCRIPTIONS,
    VERSION_HISTORY,
    deprecated_page,
    documented_ids,
    env_page,
    env_pages,
)


def test_every_registered_namespaced_id_has_a_page() -> None:
    namespaced = {i for i in vtrack_gym.ALL_ENV_IDS if i.startswith("vtrack/")}
    assert set(documented_ids()) == namespaced
    for env_id in namespaced:
        name = env_id.split("/", 1)[1]
        assert name in DESCRIPTIONS and VERSION_HISTORY[name], env_id


TEMPLATE_HEADINGS = ("# vtrack/DLC120-v0", "## Observation space", "## Action and reward",
                     "## Starting state and episode end", "## Arguments", "## Version history")


def test_pages_follow_the_template() -> None:
    """Every page built (every id made, the exact lines planned: the slow tier); one page read for the template."""
    pages = env_pages()
    assert "index.md" in pages and len(pages) == len(documented_ids()) + len(DEPRECATED_PAGES) + 1
    page = pages["DLC120-v0.md"]
    for heading in TEMPLATE_HEADINGS:
        assert heading in page
    assert "`e_y`" in page and "`Auto` success criterion" in page and "Also registered as `DLC120-v0`" in page


def test_one_page_follows_the_template() -> None:
    """The fast tier's share of the test above: the page of one id, built alone, is the one ``env_pages`` holds."""
    page = env_page("vtrack/DLC120-v0")
    for heading in TEMPLATE_HEADINGS:
        assert heading in page
    assert "`e_y`" in page and "`Auto` success criterion" in page and "Also registered as `DLC120-v0`" in page


def test_recipe_page_states_its_control_period() -> None:
    assert "| Control period | 50 ms |" in env_page("vtrack/TrainingMix20Hz-v0")


def test_changed_ids_carry_their_version_history() -> None:
    for name in ("ISO3888-1-v2", "ISO3888-2-v2", "ISO3888-1-v1", "ISO3888-2-v1"):
        history = VERSION_HISTORY[name]
        assert [line[:3] for line in history] == ["v0:", "v1:", "v2:"], name
    assert [line[:3] for line in VERSION_HISTORY["Slalom-v1"]] == ["v0:", "v1:"]
    assert VERSION_HISTORY["ISO3888-1-v0"] == VERSION_HISTORY["ISO3888-1-v1"] == VERSION_HISTORY["ISO3888-1-v2"]
    assert "entry_speed_kmh" in env_page("vtrack/ISO3888-2-v2")
    page = deprecated_page("ISO3888-2-v0")
    assert "DeprecatedEnv" in page and "ISO3888-2-v2.md" in page and "## Version history" in page
    assert "entry_speed_kmh" in env_page("vtrack/ISO3888-2-v1")
