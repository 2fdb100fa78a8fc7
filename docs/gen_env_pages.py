"""Build-time generator of the environment pages (run by mkdocs-gen-files): one page per registered id, written
from the scenario registry by ``vtrack_gym.envs.env_docs`` so the pages cannot drift from the code."""

import mkdocs_gen_files

from vtrack_gym.envs.env_docs import env_pages

for name, text in env_pages().items():
    with mkdocs_gen_files.open(f"envs/{name}", "w") as page:
        page.write(text)
