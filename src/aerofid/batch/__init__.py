"""Batches: a roll or an archive of whole frames in one run, on this machine or a Dask cluster (issue 13;
docs/batch.md).

- :mod:`~aerofid.batch.inputs`: files, folders and globs -> the scans, and each frame's key (its outputs' name);
- :mod:`~aerofid.batch.plan`: the settings and their fingerprint, each frame's outputs, when a frame is complete;
- :mod:`~aerofid.batch.job`: one frame's job (picklable, never raises) and its small record;
- :mod:`~aerofid.batch.gallery`: each frame's mark crops for review;
- :mod:`~aerofid.batch.summary`: summary.csv / .json / .html;
- :mod:`~aerofid.batch.runners`: this process, local processes, a Dask distributed cluster;
- :mod:`~aerofid.batch.driver`: plan a batch, run what is not complete, keep the summary up to date.
"""
