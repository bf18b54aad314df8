"""The words of a run's gallery: its title (the run, and what is shown: the final population,
the archive's elites or atlas, the lineage of the best) and its subtitle (the fitness and what
each label shows)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from ariel.recording.store import Run, fitness_label, one_line

if TYPE_CHECKING:
    from ariel.recording.analysis._gallery_select import Atlas, Pick

__all__ = ["gallery_subtitle", "gallery_title"]


def _run_name(run: Run) -> str:
    run_id = run.info.get("run_id")
    return one_line(run_id if isinstance(run_id, str) and run_id else run.path.name)


def gallery_subtitle(
    run: Run, key: tuple[str, str], capped: str = "", *, atlas: bool = False
) -> str:
    """The fitness and what each label shows: an atlas's tiles their id and fitness (the axes
    are the measures), other sheets' also the two key descriptors."""
    fitness = fitness_label(str(run.config.get("task", {}).get("fitness", "")), run.maximise)
    labels = f"{fitness}; each label: body id, fitness"
    labels += "" if atlas else f", {key[0]}, {key[1]}"
    return f"{labels}; {capped}" if capped else labels


def gallery_title(run: Run, of: str, chosen: list[Pick], atlas: Atlas | None, total: int) -> str:
    generation = run.generations_done - 1
    if generation < 0 or not chosen:
        why = "no finished generation yet" if generation < 0 else "no body with a fitness"
        return f"{_run_name(run)}: {why}"
    if of == "final":
        what = f"the population after generation {generation}, best first "
        what += f"({_bodies(chosen, total)})"
    elif of == "elites":
        what = f"the archive's elites after generation {generation}, best first "
        what += f"({_bodies(chosen, total)})"
    elif of == "archive" and atlas is not None:
        share = f"{atlas.filled / atlas.cells:.0%}" if atlas.cells else "-"
        what = f"the archive after generation {generation}: {atlas.filled} of {atlas.cells} "
        what += f"cells ({share})" + (", placed by their measures" if atlas.binned else "")
        what += f", the best {len(chosen)} shown" if len(chosen) < total else ""
    elif of == "archive":
        what = f"the archive's elites after generation {generation} ({_bodies(chosen, total)})"
    else:
        ancestors, nearest = total - 1, "nearest " if len(chosen) < total else ""
        what = (
            f"the best body and its {nearest}{len(chosen) - 1} of {ancestors} ancestors, "
            "oldest first"
            if nearest
            else f"the best body and its {ancestors} ancestor(s), oldest first"
            if ancestors > 0
            else "the best body (a founder: no ancestors)"
        )
    return f"{_run_name(run)}: {what}"


def _bodies(chosen: list[Pick], total: int) -> str:
    if len(chosen) < total:
        return f"the best {len(chosen)} of {total} bodies"
    return f"{len(chosen)} bod{'y' if len(chosen) == 1 else 'ies'}"
