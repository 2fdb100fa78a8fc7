"""Scoring policies on a suite or on track files, and a suite's episodes exported as a dataset."""
