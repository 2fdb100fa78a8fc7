"""Build-time generator of the CLI reference page (run by mkdocs-gen-files), written from ``vtrack``'s parser by
``vtrack_gym.cli._reference`` so the page cannot drift from the commands."""

import mkdocs_gen_files

from vtrack_gym.cli._reference import cli_reference

with mkdocs_gen_files.open("cli.md", "w") as page:
    page.write(cli_reference())
