"""The tools around the pipeline, which run and present builds and never feed them: the `nemc`
command (cli.py), tables and files of a run (report.py), figures (figures.py, typeset.py),
animation (animate.py), the equations printed (show.py), the stress report (stress.py,
stress_report.py), sweeps on a Dask cluster (sweeps.py, sweep_store.py, sweep_view.py)."""
