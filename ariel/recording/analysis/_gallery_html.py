"""The gallery's HTML page: one file, nothing to fetch (styles inline, each thumbnail a base64
``data:`` URI). A card per body: its thumbnail, id, caption, fitness, two key descriptors
(every descriptor under "descriptors") and the ``ariel`` command that opens it. An archive's
page puts the cards at their cells, the first measure across and the second growing upwards.
Every text from the run folder is escaped (`html_text`)."""

from __future__ import annotations

import base64
from typing import TYPE_CHECKING

from ariel.recording.analysis._gallery_render import cached_thumbnail
from ariel.recording.analysis._gallery_sheet import bin_text, descriptor_text, number_text
from ariel.recording.store import DESCRIPTORS, descriptor_label, html_text

if TYPE_CHECKING:
    from ariel.recording.analysis._gallery import Gallery, GalleryBody

__all__ = ["gallery_html"]

_STYLE = """
body { font: 14px/1.4 system-ui, sans-serif; color: #212529; margin: 24px; }
h1 { font-size: 20px; margin: 0 0 4px; } .sub { color: #6c757d; margin: 0 0 20px; }
.cards { display: grid; grid-template-columns: repeat(auto-fill, minmax(256px, 1fr)); gap: 16px; }
.atlas { display: grid; gap: 4px; align-items: stretch; grid-auto-rows: minmax(48px, auto); }
.card { border: 1px solid #dee2e6; border-radius: 6px; padding: 8px; background: #fff; }
.atlas .card { padding: 4px; font-size: 12px; }
.card img, .none { width: 100%; aspect-ratio: 1; display: block; border-radius: 4px; }
.none { background: #eceef0; color: #6c757d; display: grid; place-items: center; }
.empty { background: #f4f5f6; border-radius: 4px; min-height: 40px; }
.id { font-weight: 600; margin-top: 6px; } .caption { color: #6c757d; font-weight: 400; }
.key { color: #6c757d; } details { margin-top: 4px; color: #6c757d; }
code { display: block; margin-top: 6px; padding: 4px 6px; background: #f1f3f5; border-radius: 4px;
  font-size: 12px; overflow-wrap: anywhere; user-select: all; }
.axis { color: #6c757d; font-size: 12px; display: grid; place-items: center; }
.notes { color: #6c757d; margin-top: 20px; }
"""


def _image(body: GalleryBody) -> str:
    """``body``'s thumbnail as an ``<img>`` with a data URI, or a box that says it has none."""
    data = cached_thumbnail(body.thumbnail) if body.thumbnail is not None else None
    if data is None:  # not what the sheet would draw: a PNG of thumbnail size, no link
        return '<div class="none">no thumbnail</div>'
    encoded = base64.b64encode(data).decode("ascii")
    alt = html_text(f"body {body.body_id}")
    return f'<img src="data:image/png;base64,{encoded}" alt="{alt}">'


def _when(body: GalleryBody) -> str:
    """When the body lived: born in one generation, shown as it was after another (every card
    of a sheet said "generation 4", the sheet's, whatever the body's age)."""
    born = f"born in generation {body.born}, " if body.born is not None else ""
    return f"{born}as after generation {body.generation}"


def _card(body: GalleryBody, key: tuple[str, str], style: str = "") -> str:
    caption = f' <span class="caption">({html_text(body.caption)})</span>' if body.caption else ""
    every = ", ".join(
        f"{html_text(name)} {number_text(value)}" for name, value in body.descriptors.items()
    )
    return (
        f'<div class="card"{style}>{_image(body)}'
        f'<div class="id">{html_text(body.body_id)}{caption}</div>'
        f"<div>fitness {number_text(body.fitness)} · {_when(body)}</div>"
        f'<div class="key">{html_text(descriptor_text(body, key))}</div>'
        f"<details><summary>descriptors</summary>{every}</details>"
        f'<code title="{_paste_where(body)}">{html_text(body.command)}</code></div>'
    )


def _paste_where(body: GalleryBody) -> str:
    """Where the body's command runs (`GalleryBody.from_parent`): a page in a run or campaign
    folder names the run from the folder holding that one."""
    if body.from_parent:
        return "paste into a shell in the folder that holds this run (or campaign) folder"
    return "paste into a shell"


def _how_to_paste(gallery: Gallery) -> str:
    """The page's own word on its commands (a hover title alone was missed: pasted at the
    repository's root, the commands failed twice, for the folder and for a bare ``ariel``)."""
    if any(body.from_parent for body in gallery.bodies):
        return (
            "Each card's command opens that evaluation: paste it into a shell in the folder "
            "that holds the run (or campaign) folder, with ariel on the PATH (or give its "
            "path, such as .venv/bin/ariel)."
        )
    return (
        "Each card's command opens that evaluation: paste it into a shell in the folder the "
        "gallery was made from."
    )


def _atlas(gallery: Gallery) -> str:
    atlas = gallery.atlas
    assert atlas is not None  # an archive's gallery (`gallery_html` checks)
    across, up = atlas.measures
    whole = [DESCRIPTORS.get(m, ("", False))[1] for m in atlas.measures]  # across, up
    parts = [
        f'<div class="atlas" style="grid-template-columns: 64px repeat({atlas.columns}, '
        'minmax(120px, 220px))">'
    ]
    for row in range(atlas.rows):
        line = atlas.rows - row  # the second measure grows upwards: row 0 is drawn last
        label = bin_text(atlas.row_edges[row], atlas.row_edges[row + 1], whole[1])
        parts.append(f'<div class="axis" style="grid-row: {line}; grid-column: 1">{label}</div>')
        for column in range(atlas.columns):
            place = f"grid-row: {line}; grid-column: {column + 2}"
            parts.append(f'<div class="empty" style="{place}"></div>')
    for column in range(atlas.columns):
        label = bin_text(atlas.column_edges[column], atlas.column_edges[column + 1], whole[0])
        place = f"grid-row: {atlas.rows + 1}; grid-column: {column + 2}"
        parts.append(f'<div class="axis" style="{place}">{label}</div>')
    for body in gallery.bodies:
        assert body.cell is not None  # every body of an atlas has its cell
        row, column = body.cell
        place = f' style="grid-row: {atlas.rows - row}; grid-column: {column + 2}"'
        parts.append(_card(body, gallery.key_descriptors, place))
    parts.append("</div>")
    axes = f"columns: {html_text(descriptor_label(across))}; rows (growing upwards): "
    axes += html_text(descriptor_label(up))
    return f'<p class="sub">{axes}</p>' + "".join(parts)


def gallery_html(gallery: Gallery) -> str:
    """The page of ``gallery`` (a `Gallery` whose bodies are final), as text."""
    if gallery.atlas is not None:
        body = _atlas(gallery)
    else:
        cards = "".join(_card(b, gallery.key_descriptors) for b in gallery.bodies)
        body = f'<div class="cards">{cards or "no bodies to show"}</div>'
    notes = "".join(f"<li>{html_text(note)}</li>" for note in gallery.notes)
    return (
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
        '<meta name="viewport" content="width=device-width, initial-scale=1">'
        f"<title>{html_text(gallery.title)}</title><style>{_STYLE}</style></head><body>"
        f'<h1>{html_text(gallery.title)}</h1><p class="sub">{html_text(gallery.subtitle)}</p>'
        + (f'<p class="sub">{html_text(_how_to_paste(gallery))}</p>' if gallery.bodies else "")
        + f"{body}"
        + (f'<ul class="notes">{notes}</ul>' if notes else "")
        + "</body></html>\n"
    )
