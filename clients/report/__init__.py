"""``riverbridge report``: where time and bytes go, per topic and stage, beside the thesis.

:mod:`clients.report.cli` runs the stack (or attaches to one) and measures it; the rest is
pure: spans joined into journeys and summarised (:mod:`clients.report.stats`), the thesis's
figures (:mod:`clients.report.thesis`), detection quality (:mod:`clients.report.quality`),
socket byte counters (:mod:`clients.report.sockets`), text tables
(:mod:`clients.report.text`) and plots (:mod:`clients.report.plots`). README.md in this
folder is the map.
"""
