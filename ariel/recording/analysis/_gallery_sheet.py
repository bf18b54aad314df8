"""The gallery's PNG: a contact sheet (thumbnails in rows, each labelled with its body id,
caption, fitness and two key descriptors) or, for an archive, its atlas (each elite's thumbnail
at its cell in the grid of the two measures, the first across and the second growing upwards,
as in the report's heatmap and the Rerun viewer). Drawn with Pillow; a body without a
thumbnail gets a grey tile that says so."""

from __future__ import annotations

import io
import math
import warnings
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from PIL import Image, ImageDraw, ImageFont

from ariel.recording.analysis._gallery_render import cached_thumbnail
from ariel.recording.store import DESCRIPTORS, descriptor_label

if TYPE_CHECKING:
    from ariel.recording.analysis._gallery import Gallery, GalleryBody
    from ariel.recording.analysis._gallery_select import Atlas

_Font = ImageFont.FreeTypeFont | ImageFont.ImageFont

__all__ = [
    "atlas_sheet",
    "bin_text",
    "contact_sheet",
    "descriptor_text",
    "number_text",
    "sheet_grid",
]

BACKGROUND, INK, FAINT, EMPTY = (255, 255, 255), (33, 37, 41), (108, 117, 125), (236, 238, 240)
MARGIN, GAP, LINE = 16, 12, 18
COLUMNS = 6  # a contact sheet's thumbnails per row at most


def _font(size: int) -> _Font:
    try:
        return ImageFont.load_default(size=size)
    except (TypeError, OSError, ImportError):  # Pillow without FreeType: the bitmap font
        return ImageFont.load_default()


def number_text(value: Any) -> str:
    """A fitness or descriptor value, short: ``0.4558``, ``10``, ``-`` for none."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        return "-"
    if not math.isfinite(number):
        return "-"
    return f"{number:.0f}" if number.is_integer() and abs(number) < 1e6 else f"{number:.4g}"


def descriptor_text(body: GalleryBody, names: Sequence[str]) -> str:
    """``num_modules 10 · num_hinges 4`` for ``body`` (a `GalleryBody`)."""
    return " · ".join(f"{name} {number_text(body.descriptors.get(name))}" for name in names)


def _fitted(draw: ImageDraw.ImageDraw, text: str, font: _Font, width: int) -> str:
    """``text`` cut in the middle (an ellipsis there) to fit ``width`` pixels, its start and
    its end kept: names that differ at the end (``..._variant_A, seed 2)``) stay apart. At most
    ``width`` characters are measured (a label holds no more than one a pixel; PIL refuses a
    string of a million); the longest that fits is found by halving (a few measurements, not
    one per character)."""
    if len(text) <= width and draw.textlength(text, font=font) <= width:
        return text

    def kept(count: int) -> str:  # ``count`` characters of ``text``: half its start, half its end
        head = (count + 1) // 2
        return text[:head] + "…" + text[len(text) - (count - head) :]

    fits, too_long = 0, min(len(text), width) + 1  # kept(fits) fits; kept(too_long) does not
    while too_long - fits > 1:
        middle = (fits + too_long) // 2
        if draw.textlength(kept(middle), font=font) <= width:
            fits = middle
        else:
            too_long = middle
    return kept(fits)


def _thumbnail(body: GalleryBody, size: int) -> Image.Image:
    """``body``'s thumbnail at ``size`` pixels, or a grey tile saying it has none."""
    # what the page embeds too: a PNG of thumbnail size (its header says), no link
    data = cached_thumbnail(body.thumbnail) if body.thumbnail is not None else None
    if data is not None:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("error", Image.DecompressionBombWarning)
                with Image.open(io.BytesIO(data)) as image:
                    return image.convert("RGB").resize((size, size), Image.Resampling.LANCZOS)
        except (OSError, ValueError, Image.DecompressionBombError, Image.DecompressionBombWarning):
            pass  # damaged past its header: drawn as missing
    tile = Image.new("RGB", (size, size), EMPTY)
    draw = ImageDraw.Draw(tile)
    draw.text((size / 2, size / 2), "no thumbnail", fill=FAINT, font=_font(13), anchor="mm")
    return tile


TITLE_LINE = 28  # pixels a line of the title takes (LINE: one of the subtitle)
#: Lines the title and the subtitle wrap to at most (the last is cut where they need more).
TITLE_LINES, SUBTITLE_LINES = 2, 3


def _wrapped(draw: ImageDraw.ImageDraw, text: str, font: _Font, width: int, most: int) -> list[str]:
    """``text`` in lines of at most ``width`` pixels, broken between words, at most ``most``
    of them (the last cut with an ellipsis); a word wider than a line is cut."""
    words = text[: most * width].split(" ")  # a line holds no more than one a pixel
    lines: list[str] = []
    for word in words:
        joined = f"{lines[-1]} {word}" if lines else word
        if lines and draw.textlength(joined, font=font) <= width:
            lines[-1] = joined
        elif len(lines) < most:
            lines.append(word)
        else:  # no room for another line: the rest goes on the last, which is then cut
            lines[-1] = joined
    return [_fitted(draw, line, font, width) for line in lines]


def _header(title: str, subtitle: str, width: int) -> tuple[list[str], list[str], int]:
    """The title's and the subtitle's lines (wrapped to ``width`` pixels) and the height the
    two take, with the gap below them."""
    measure = ImageDraw.Draw(Image.new("RGB", (1, 1)))
    titles = _wrapped(measure, title, _font(20), width, TITLE_LINES)
    subtitles = _wrapped(measure, subtitle, _font(14), width, SUBTITLE_LINES)
    height = MARGIN + TITLE_LINE * len(titles) + LINE * max(1, len(subtitles)) + GAP
    return titles, subtitles, height


def _title(draw: ImageDraw.ImageDraw, header: tuple[list[str], list[str], int]) -> None:
    """The title and subtitle lines (`_header`) at the top."""
    titles, subtitles, _ = header
    for k, line in enumerate(titles):
        draw.text((MARGIN, MARGIN + k * TITLE_LINE), line, fill=INK, font=_font(20))
    below = MARGIN + len(titles) * TITLE_LINE
    for k, line in enumerate(subtitles):
        draw.text((MARGIN, below + k * LINE), line, fill=FAINT, font=_font(14))


def sheet_grid(count: int) -> tuple[int, int]:
    """Columns and rows of a contact sheet of ``count`` thumbnails: rows of at most `COLUMNS`,
    as even as they can be (8: two rows of 4, not 6 and 2)."""
    rows = max(1, math.ceil(count / COLUMNS))
    return max(1, math.ceil(count / rows)), rows


def contact_sheet(gallery: Gallery, size: int) -> Image.Image:
    """Every body of ``gallery`` in rows of up to `COLUMNS`, labelled (see the module)."""
    bodies = gallery.bodies
    columns, rows = sheet_grid(len(bodies))
    label = 3 * LINE + 6
    width = max(2 * MARGIN + columns * size + (columns - 1) * GAP, 640)
    header = _header(gallery.title, gallery.subtitle, width - 2 * MARGIN)
    top = header[2]
    height = top + rows * (size + label + GAP) + MARGIN
    sheet = Image.new("RGB", (width, height), BACKGROUND)
    draw = ImageDraw.Draw(sheet)
    _title(draw, header)
    if not bodies:
        draw.text((MARGIN, top), "no bodies to show", fill=FAINT, font=_font(14))
    bold, small = _font(15), _font(13)
    for k, body in enumerate(bodies):
        x = MARGIN + (k % columns) * (size + GAP)
        y = top + (k // columns) * (size + label + GAP)
        sheet.paste(_thumbnail(body, size), (x, y))
        heading = body.body_id + (f"  ({body.caption})" if body.caption else "")
        lines = [
            (_fitted(draw, heading, bold, size), bold, INK),
            (f"fitness {number_text(body.fitness)}", small, INK),
            (
                _fitted(draw, descriptor_text(body, gallery.key_descriptors), small, size),
                small,
                FAINT,
            ),
        ]
        for i, (text, font, colour) in enumerate(lines):
            draw.text((x, y + size + 4 + i * LINE), text, fill=colour, font=font)
    return sheet


def bin_text(low: float, high: float, whole: bool) -> str:
    """A bin's label: ``3`` for a bin of one whole number, else ``0.25 to 0.375``."""
    if whole and math.ceil(low) >= math.ceil(high) - 1:
        return f"{math.ceil(low)}"
    return f"{low:.3g} to {high:.3g}"


def _cell_size(atlas: Atlas, size: int) -> int:
    """Pixels per cell: the thumbnail's, smaller for big grids (about 1600 pixels across)."""
    return max(64, min(size, 1600 // max(atlas.rows, atlas.columns)))


def _whole(measure: str) -> bool:
    """Whether ``measure`` is a count (its bins then labelled by their whole number)."""
    return bool(DESCRIPTORS.get(measure, ("", False))[1])


def _atlas_axes(sheet: Image.Image, atlas: Atlas, corner: tuple[int, int], cell: int) -> None:
    """The empty cells, each row's and column's bin, and both measures' names."""
    draw, (left, top) = ImageDraw.Draw(sheet), corner
    small = _font(12 if cell >= 100 else 10)
    across, up = atlas.measures
    for row in range(atlas.rows):  # the second measure grows upwards: row 0 at the bottom
        y = top + (atlas.rows - 1 - row) * cell
        text = bin_text(atlas.row_edges[row], atlas.row_edges[row + 1], _whole(up))
        draw.text((left - 8, y + cell / 2), text, fill=FAINT, font=small, anchor="rm")
        for x in range(left, left + atlas.columns * cell, cell):
            draw.rectangle((x, y, x + cell - 2, y + cell - 2), fill=EMPTY)
    bottom = top + atlas.rows * cell + 4
    for column in range(atlas.columns):
        text = bin_text(atlas.column_edges[column], atlas.column_edges[column + 1], _whole(across))
        x = left + column * cell + cell / 2
        draw.text((x, bottom), text, fill=FAINT, font=small, anchor="ma")
    middle = (left + atlas.columns * cell / 2, bottom + LINE + 2)
    draw.text(middle, descriptor_label(across), fill=INK, font=_font(14), anchor="ma")
    _vertical_text(sheet, descriptor_label(up), (MARGIN, top + atlas.rows * cell / 2))


def _atlas_bodies(sheet: Image.Image, gallery: Gallery, corner: tuple[int, int], cell: int) -> None:
    """Each elite's thumbnail at its cell, its id and fitness along the lower edge."""
    assert gallery.atlas is not None  # an archive's gallery (`atlas_sheet`)
    draw, (left, top), rows = ImageDraw.Draw(sheet), corner, gallery.atlas.rows
    small = _font(12 if cell >= 100 else 10)
    for body in gallery.bodies:
        assert body.cell is not None  # every body of an atlas has its cell
        row, column = body.cell
        x, y = left + column * cell, top + (rows - 1 - row) * cell
        sheet.paste(_thumbnail(body, cell - 2), (x, y))
        if cell >= 100:  # room for a label on the picture
            text = _fitted(draw, f"{body.body_id}  {number_text(body.fitness)}", small, cell - 8)
            band = y + cell - 2 - LINE
            draw.rectangle((x, band, x + cell - 3, y + cell - 3), fill=BACKGROUND)
            draw.text((x + 4, band + 2), text, fill=INK, font=small)


def atlas_sheet(gallery: Gallery, size: int) -> Image.Image:
    """``gallery``'s elites at their cells (``gallery.atlas``), with both measures' bins."""
    assert gallery.atlas is not None  # an archive's gallery (`_gallery._write` checks)
    atlas, cell = gallery.atlas, _cell_size(gallery.atlas, size)
    left = MARGIN + LINE + 90  # the second measure's name, turned, then its bins
    width = max(left + atlas.columns * cell + MARGIN, 640)
    header = _header(gallery.title, gallery.subtitle, width - 2 * MARGIN)
    top = header[2]
    height = top + atlas.rows * cell + 2 * LINE + GAP + MARGIN
    sheet = Image.new("RGB", (width, height), BACKGROUND)
    _title(ImageDraw.Draw(sheet), header)
    _atlas_axes(sheet, atlas, (left, top), cell)
    _atlas_bodies(sheet, gallery, (left, top), cell)
    return sheet


def _vertical_text(sheet: Image.Image, text: str, at: tuple[float, float]) -> None:
    """``text`` turned a quarter left, its middle at ``at``'s height, its left at ``at``'s x."""
    font = _font(14)
    text = _fitted(ImageDraw.Draw(sheet), text, font, sheet.height)  # a run.json's measure
    width = int(ImageDraw.Draw(sheet).textlength(text, font=font)) + 4
    label = Image.new("RGB", (width, LINE + 4), BACKGROUND)
    ImageDraw.Draw(label).text((2, 2), text, fill=INK, font=font)
    turned = label.rotate(90, expand=True)
    sheet.paste(turned, (int(at[0]), int(at[1] - turned.height / 2)))
