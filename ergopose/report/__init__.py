"""HTML ergonomic reports of a session: one self-contained page per worker and a session index.

- :mod:`ergopose.report.context`: report input records (frozen dataclasses, stored as JSON).
- :mod:`ergopose.report.results`: the stored-results folder (save_results / load_results).
- :mod:`ergopose.report.adapters`: other stages' records -> report input records.
- :mod:`ergopose.report.page_types`: one typed context per template; :mod:`ergopose.report.pages`
  builds them from the records with the sections of :mod:`ergopose.report.session_sections`
  (session-level), :mod:`ergopose.report.worker_sections` (a worker's headline and tables),
  :mod:`ergopose.report.timelines` (risk over time and over the floor) and
  :mod:`ergopose.report.quality_section` (limb lengths), and the words and numbers of
  :mod:`ergopose.report.wording`.
- inline SVG figures: :mod:`ergopose.report.charts` (bars, columns, box plots),
  :mod:`ergopose.report.time_charts` (over the shift), :mod:`ergopose.report.heat_maps` (floor),
  :mod:`ergopose.report.skeleton_drawing` (worst moments), on the primitives of
  :mod:`ergopose.report.svg`; :mod:`ergopose.report.quality`: trust verdict.
- :mod:`ergopose.report.render`: render_report(report_dir) writes the pages atomically.

docs/reports.md describes the pages, the stored results and every rule the report applies.
"""
