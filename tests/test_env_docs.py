"""Every registered id has its documentation page (generated from the registry by ``vtrack_gym.envs.env_docs``),
with a description and a version history, so a scenario added without docs fails here."""

from __future__ import annotations

import vtrack_gym
from vtrack_gym.envs.env_docs import DESCRIPTIONS, VERSION_HISTORY, documented_ids, env_page, env_pages


def test_every_registered_namespaced_id_has_a_page() -> None:
    namespaced = {i for i in vtrack_gym.ALL_ENV_IDS if i.startswith("vtrack/")}
    assert set(documented_ids()) == namespaced
    for env_id in namespaced:
        name = env_id.split("/", 1)[1]
        assert name in DESCRIPTIONS and VERSION_HISTORY[name], env_id


def test_pages_follow_the_template() -> None:
    pages = env_pages()
    assert "index.md" in pages and len(pages) == len(documented_ids()) + 1
    page = pages["DLC120-v0.md"]
    for heading in ("# vtrack/DLC120-v0", "## Observation space", "## Action and reward",
                    "## Starting state and episode end", "## Arguments", "## Version history"):
        assert heading in page
    assert "`e_y`" in page and "`Auto` success criterion" in page and "Also registered as `DLC120-v0`" in page


def test_recipe_page_states_its_control_period() -> None:
    assert "| Control period | 50 ms |" in env_page("vtrack/TrainingMix20Hz-v0")
