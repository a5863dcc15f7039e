# SPDX-License-Identifier: GPL-3.0-or-later
"""Morphable faces (thesis 3.2 and 5.1, mind2model): a PCA model of faces in correspondence, intuitive
attributes learned from rated examples, Mahalanobis navigation, constraints, segments with smooth blending,
feature import, caricatures; loaders for the common 3DMM files; and a default model learned from a synthetic
population sampled from published craniofacial norms (:mod:`.population`)."""
