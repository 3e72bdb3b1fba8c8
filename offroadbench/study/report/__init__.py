"""A study's report: the Markdown report, its header, the paper and planner sections and the HTML page."""

from offroadbench.study.report.header import driver_files, held_fixed, report_title, settings_columns, soil_conditions
from offroadbench.study.report.html import markdown_to_html, replay_anchor, report_html
from offroadbench.study.report.markdown import Report, build_report, markdown_table

__all__ = ['driver_files', 'held_fixed', 'report_title', 'settings_columns', 'soil_conditions', 'markdown_to_html', 'replay_anchor', 'report_html', 'Report', 'build_report', 'markdown_table']
