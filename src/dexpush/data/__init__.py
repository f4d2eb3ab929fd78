"""Recorded pushes: push logs, the MIT push dataset, fitting λ to pushes, the model's validation
and the online estimator over recordings."""
