"""The run folder on disk, written and read back: its files, lock, manifest, Parquet tables
and their rows, `load_run` and `load_campaign`, and the generation statistics.

Cheap to import: names are loaded from their modules on first use (`ariel.utils.lazy`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ariel.utils.lazy import lazy_face

if TYPE_CHECKING:  # what ARIEL's other packages import from here (not the API)
    from ariel.recording.store._archive import (
        archive_cell_count as archive_cell_count,
        archive_damage as archive_damage,
        describe_archive as describe_archive,
    )
    from ariel.recording.store._axes import (
        DESCRIPTORS as DESCRIPTORS,
        condition_colours as condition_colours,
        descriptor_label as descriptor_label,
        fitness_label as fitness_label,
        fitness_unit as fitness_unit,
        fitted as fitted,
        integer_ticks as integer_ticks,
    )
    from ariel.recording.store._campaign import (
        CAMPAIGN_JSON as CAMPAIGN_JSON,
        CAMPAIGN_RRD as CAMPAIGN_RRD,
        Campaign as Campaign,
        fitness_maximise as fitness_maximise,
        is_campaign as is_campaign,
        load_campaign as load_campaign,
        read_campaign_info as read_campaign_info,
        run_path as run_path,
        write_campaign_info as write_campaign_info,
    )
    from ariel.recording.store._curves import (
        best_so_far as best_so_far,
        on_grid as on_grid,
    )
    from ariel.recording.store._escape import (
        csv_safe as csv_safe,
        figure_label as figure_label,
        html_text as html_text,
        markdown_cell as markdown_cell,
        markdown_code as markdown_code,
        markdown_text as markdown_text,
        one_line as one_line,
        short_ascii as short_ascii,
        terminal_text as terminal_text,
    )
    from ariel.recording.store._files import (
        STALE_S as STALE_S,
        UnsafePathError as UnsafePathError,
        atomic_write as atomic_write,
        atomic_write_bytes as atomic_write_bytes,
        cannot_write as cannot_write,
        check_path_names as check_path_names,
        damaged as damaged,
        fsync_folder as fsync_folder,
        output_file_problem as output_file_problem,
        records_folder_of as records_folder_of,
        refuse_symlinks as refuse_symlinks,
        remove_temporaries as remove_temporaries,
        user_file as user_file,
        within as within,
        written_path as written_path,
    )
    from ariel.recording.store._ids import (
        check_body_id as check_body_id,
        check_eval_id as check_eval_id,
        check_new_id as check_new_id,
        check_run_id as check_run_id,
    )
    from ariel.recording.store._lineage import (
        ancestors as ancestors,
        lineage as lineage,
        lineage_statistics as lineage_statistics,
        lineage_statistics_by_run as lineage_statistics_by_run,
        parse_ancestor_list as parse_ancestor_list,
        write_lineage_csv as write_lineage_csv,
    )
    from ariel.recording.store._list_runs import (
        STOPPED as STOPPED,
        UNREADABLE as UNREADABLE,
        RunSummary as RunSummary,
        list_runs as list_runs,
    )
    from ariel.recording.store._load import (
        QD_COLUMNS as QD_COLUMNS,
        Run as Run,
        archive_quality_table as archive_quality_table,
        load_run as load_run,
        population_after_selection as population_after_selection,
        stored_graph_key as stored_graph_key,
    )
    from ariel.recording.store._lock import (
        LOCK_NAME as LOCK_NAME,
        RunInUseError as RunInUseError,
        RunLock as RunLock,
        ensure_open_files as ensure_open_files,
        holder_gone as holder_gone,
    )
    from ariel.recording.store._manifest import (
        MANIFEST_FORMAT as MANIFEST_FORMAT,
        Manifest as Manifest,
        manifest_entries as manifest_entries,
        manifest_file as manifest_file,
        manifests_expected as manifests_expected,
    )
    from ariel.recording.store._provenance import (
        git_commit as git_commit,
        now as now,
        software_versions as software_versions,
        version_differences as version_differences,
    )
    from ariel.recording.store._prune import (
        PruneError as PruneError,
        prunable_runs as prunable_runs,
        prune_run as prune_run,
    )
    from ariel.recording.store._row_types import (
        EvaluationRow as EvaluationRow,
    )
    from ariel.recording.store._rows import (
        RunWriter as RunWriter,
        body_rows_of as body_rows_of,
        evaluation_row as evaluation_row,
    )
    from ariel.recording.store._run_folder import (
        DamagedRunError as DamagedRunError,
        JsonObject as JsonObject,
        NotARunError as NotARunError,
        RunFolder as RunFolder,
        RunStorageError as RunStorageError,
        finished_generations as finished_generations,
        json_data as json_data,
        json_file as json_file,
        storage_errors as storage_errors,
    )
    from ariel.recording.store._table_limits import (
        config_sections as config_sections,
        section_problem as section_problem,
    )
    from ariel.recording.store._tables import (
        GENERATION_BLUEPRINT as GENERATION_BLUEPRINT,
        evaluation_trajectory as evaluation_trajectory,
        generation_file as generation_file,
        generation_recording_path as generation_recording_path,
        read_file as read_file,
        read_table as read_table,
        recording_path as recording_path,
        table_schema as table_schema,
        to_pandas as to_pandas,
    )
    from ariel.recording.store._verify import (
        adopt_manifests as adopt_manifests,
        verify_run as verify_run,
    )

# name -> module that defines it: for ARIEL's other packages, not part of the API
_INTERNAL: dict[str, str] = {
    "CAMPAIGN_JSON": "ariel.recording.store._campaign",
    "CAMPAIGN_RRD": "ariel.recording.store._campaign",
    "Campaign": "ariel.recording.store._campaign",
    "DESCRIPTORS": "ariel.recording.store._axes",
    "DamagedRunError": "ariel.recording.store._run_folder",
    "EvaluationRow": "ariel.recording.store._row_types",
    "GENERATION_BLUEPRINT": "ariel.recording.store._tables",
    "JsonObject": "ariel.recording.store._run_folder",
    "MANIFEST_FORMAT": "ariel.recording.store._manifest",
    "Manifest": "ariel.recording.store._manifest",
    "NotARunError": "ariel.recording.store._run_folder",
    "PruneError": "ariel.recording.store._prune",
    "QD_COLUMNS": "ariel.recording.store._load",
    "Run": "ariel.recording.store._load",
    "RunSummary": "ariel.recording.store._list_runs",
    "RunFolder": "ariel.recording.store._run_folder",
    "RunInUseError": "ariel.recording.store._lock",
    "LOCK_NAME": "ariel.recording.store._lock",
    "RunLock": "ariel.recording.store._lock",
    "RunStorageError": "ariel.recording.store._run_folder",
    "RunWriter": "ariel.recording.store._rows",
    "body_rows_of": "ariel.recording.store._rows",
    "evaluation_row": "ariel.recording.store._rows",
    "STOPPED": "ariel.recording.store._list_runs",
    "UNREADABLE": "ariel.recording.store._list_runs",
    "UnsafePathError": "ariel.recording.store._files",
    "adopt_manifests": "ariel.recording.store._verify",
    "ancestors": "ariel.recording.store._lineage",
    "archive_cell_count": "ariel.recording.store._archive",
    "archive_damage": "ariel.recording.store._archive",
    "archive_quality_table": "ariel.recording.store._load",
    "atomic_write": "ariel.recording.store._files",
    "atomic_write_bytes": "ariel.recording.store._files",
    "best_so_far": "ariel.recording.store._curves",
    "cannot_write": "ariel.recording.store._files",
    "check_path_names": "ariel.recording.store._files",
    "damaged": "ariel.recording.store._files",
    "fsync_folder": "ariel.recording.store._files",
    "check_body_id": "ariel.recording.store._ids",
    "check_eval_id": "ariel.recording.store._ids",
    "config_sections": "ariel.recording.store._table_limits",
    "section_problem": "ariel.recording.store._table_limits",
    "check_new_id": "ariel.recording.store._ids",
    "check_run_id": "ariel.recording.store._ids",
    "csv_safe": "ariel.recording.store._escape",
    "describe_archive": "ariel.recording.store._archive",
    "descriptor_label": "ariel.recording.store._axes",
    "ensure_open_files": "ariel.recording.store._lock",
    "evaluation_trajectory": "ariel.recording.store._tables",
    "figure_label": "ariel.recording.store._escape",
    "fitness_label": "ariel.recording.store._axes",
    "fitness_maximise": "ariel.recording.store._campaign",
    "fitness_unit": "ariel.recording.store._axes",
    "fitted": "ariel.recording.store._axes",
    "generation_file": "ariel.recording.store._tables",
    "generation_recording_path": "ariel.recording.store._tables",
    "git_commit": "ariel.recording.store._provenance",
    "holder_gone": "ariel.recording.store._lock",
    "html_text": "ariel.recording.store._escape",
    "integer_ticks": "ariel.recording.store._axes",
    "condition_colours": "ariel.recording.store._axes",
    "is_campaign": "ariel.recording.store._campaign",
    "json_data": "ariel.recording.store._run_folder",
    "finished_generations": "ariel.recording.store._run_folder",
    "json_file": "ariel.recording.store._run_folder",
    "lineage": "ariel.recording.store._lineage",
    "lineage_statistics": "ariel.recording.store._lineage",
    "lineage_statistics_by_run": "ariel.recording.store._lineage",
    "list_runs": "ariel.recording.store._list_runs",
    "load_campaign": "ariel.recording.store._campaign",
    "load_run": "ariel.recording.store._load",
    "manifest_entries": "ariel.recording.store._manifest",
    "manifest_file": "ariel.recording.store._manifest",
    "manifests_expected": "ariel.recording.store._manifest",
    "markdown_cell": "ariel.recording.store._escape",
    "markdown_code": "ariel.recording.store._escape",
    "markdown_text": "ariel.recording.store._escape",
    "now": "ariel.recording.store._provenance",
    "on_grid": "ariel.recording.store._curves",
    "parse_ancestor_list": "ariel.recording.store._lineage",
    "one_line": "ariel.recording.store._escape",
    "population_after_selection": "ariel.recording.store._load",
    "stored_graph_key": "ariel.recording.store._load",
    "prunable_runs": "ariel.recording.store._prune",
    "prune_run": "ariel.recording.store._prune",
    "read_campaign_info": "ariel.recording.store._campaign",
    "read_file": "ariel.recording.store._tables",
    "read_table": "ariel.recording.store._tables",
    "recording_path": "ariel.recording.store._tables",
    "output_file_problem": "ariel.recording.store._files",
    "records_folder_of": "ariel.recording.store._files",
    "refuse_symlinks": "ariel.recording.store._files",
    "user_file": "ariel.recording.store._files",
    "within": "ariel.recording.store._files",
    "STALE_S": "ariel.recording.store._files",
    "remove_temporaries": "ariel.recording.store._files",
    "run_path": "ariel.recording.store._campaign",
    "short_ascii": "ariel.recording.store._escape",
    "software_versions": "ariel.recording.store._provenance",
    "version_differences": "ariel.recording.store._provenance",
    "storage_errors": "ariel.recording.store._run_folder",
    "table_schema": "ariel.recording.store._tables",
    "terminal_text": "ariel.recording.store._escape",
    "to_pandas": "ariel.recording.store._tables",
    "verify_run": "ariel.recording.store._verify",
    "write_campaign_info": "ariel.recording.store._campaign",
    "write_lineage_csv": "ariel.recording.store._lineage",
    "written_path": "ariel.recording.store._files",
}

__getattr__, __dir__ = lazy_face(__name__, _INTERNAL)
