"""mkdocs hooks of the docs site (mkdocs.yml ``hooks:``): the pages written from the code.

- ``index.md``: the README, its links made relative to the site.
- ``cli.md``: the command-line reference, from the argparse parser (cli_page.py).
- ``reference/``: one page per public module (api_pages.py), and its navigation.
- ``analysis/*.ipynb``: the analysis notebooks, run by mkdocs-jupyter on the small run and
  campaign that docs_data.py makes under .cache/docs/ (their folders are passed to the
  kernels through ARIEL_RUN_DIR and ARIEL_CAMPAIGN_DIR, as a user would).

ARIEL_DOCS_EXECUTE=0 builds without running any notebook (and without making the data): the
pages, links and API reference only. ARIEL_DOCS_API=0 leaves out the module pages too (the
reference's entry page stays): a build of seconds, for the tests of the build itself.
"""

from __future__ import annotations

import logging
import os
import posixpath
import re
import sys
from pathlib import Path

from mkdocs.structure.files import File, Files
from mkdocs_jupyter.plugin import NotebookFile

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
sys.path.insert(0, str(HERE))

import api_pages  # noqa: E402
import cli_page  # noqa: E402
import docs_data  # noqa: E402

# A warning under the "mkdocs" logger fails a --strict build.
log = logging.getLogger("mkdocs.hooks.ariel")
API_NAV_TITLE = "API reference"
ANALYSIS_NOTEBOOKS = ("fitness_and_diversity", "gait_of_best", "compare_conditions")


def _executing() -> bool:
    return os.environ.get("ARIEL_DOCS_EXECUTE", "1") != "0"


def _modules() -> list:
    with_api = os.environ.get("ARIEL_DOCS_API", "1") != "0"
    return api_pages.public_modules() if with_api else []


def on_config(config):
    for entry in config["nav"]:
        if isinstance(entry, dict) and API_NAV_TITLE in entry:
            entry[API_NAV_TITLE] = api_pages.nav(_modules())
    if _executing():
        data = docs_data.prepare(ROOT / ".cache" / "docs")
        os.environ["ARIEL_RUN_DIR"] = str(data.run)
        os.environ["ARIEL_CAMPAIGN_DIR"] = str(data.campaign)
    else:
        config["plugins"]["mkdocs-jupyter"].config["execute"] = False
    return config


def readme_markdown() -> str:
    """The README as the site's first page: links into docs/ become links within the site,
    and its link to the built site (site/index.html) a link to this page."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    return re.sub(r"\]\(docs/", "](", text).replace("](site/index.html)", "](index.md)")


def on_files(files: Files, config) -> Files:
    modules = _modules()
    generated = {
        "index.md": readme_markdown(),
        "cli.md": cli_page.markdown(),
        "reference/index.md": api_pages.index(modules),
    }
    for module in modules:
        generated[api_pages.page_path(module.__name__)] = api_pages.page(module)
    for path, content in generated.items():
        files.append(File.generated(config, path, content=content))
    for name in ANALYSIS_NOTEBOOKS:
        notebook = File(
            f"analysis/{name}.ipynb",
            src_dir=str(ROOT),
            dest_dir=config["site_dir"],
            use_directory_urls=config["use_directory_urls"],
        )
        # mkdocs-jupyter made its pages from the files before this hook ran: this one too.
        files.append(NotebookFile(notebook, **config))
    global _FILES
    _FILES = files
    return files


_FILES: Files | None = None
_MD_LINK = re.compile(r'href="(?![a-z]+:|#|/)([^"#]+\.(?:md|ipynb))(#[^"]*)?"')


def on_post_page(output: str, page, config) -> str:
    """Links in a notebook page's Markdown cells (``../records.md#anchor``, as they work in
    Jupyter) become the site's URLs; one to a page that does not exist fails the build, as a
    broken link in any other page does. mkdocs checks only Markdown pages' links itself."""
    if not page.file.src_uri.endswith(".ipynb") or _FILES is None:
        return output

    def replace(match: re.Match[str]) -> str:
        target = posixpath.normpath(posixpath.join(posixpath.dirname(page.file.src_uri), match[1]))
        found = _FILES.get_file_from_path(target)
        if found is None:
            log.warning("%s links to '%s', which is not in the site", page.file.src_uri, match[1])
            return match[0]
        return f'href="{found.url_relative_to(page.file)}{match[2] or ""}"'

    return _MD_LINK.sub(replace, output)
