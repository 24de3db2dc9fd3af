"""Surface reconstruction from contacts: GPIS, meshing, metrics, figures.

Public API:

* :class:`GPIS` (fit / add contacts, mean, gradient, variance, mesh) and :class:`VarianceTracker`;
  kernels :class:`ThinPlateKernel`, :class:`ReferenceThinPlateKernel`,
  :class:`SquaredExponentialKernel`, :class:`QuadraticTrend`, :data:`KERNEL_NAMES`;
* :class:`PartitionedGPIS` (a partition of unity of local GPIS fits on a density-adaptive octree;
  an option, not the default: BENCHMARKS.md, issue 10);
* :func:`mesh_zero_level` (coarse-to-fine marching cubes of any implicit function);
* :func:`confident_surface` (cut the faces where the posterior std of ``f`` is above a bound);
* :func:`add_outside_evidence` (value rows where the mean puts solid well outside the contacts'
  convex hull and tangent planes, or in front of a flat face no contact lies in front of:
  :func:`supporting_face_planes` -> :class:`FacePlanes`; ``GPIS.mesh()`` applies it to a copy by
  default); :func:`whole_face_planes` (those patches grown to whole flat faces, whose planes
  ``GPIS.mesh()`` cuts the surface at by default); :func:`supporting_contact_faces` (-> :class:`ContactFaces`: each contact's face with how
  well its normal is known; the symmetry search refuses a transform that turns one face onto another);
* :func:`find_symmetry` (-> :class:`Symmetry`, settings :class:`SymmetrySettings`): mirror planes
  or an axis of revolution the contacts support, whose images of the contacts fill sampling gaps
  (``GPIS.mesh(symmetry=True)``), less the images the hull and the GPIS both put off the surface
  (:func:`contradicted_images`) and the images of contacts the rest of the field puts in free space
  (:func:`disputed_contacts`); :func:`profile_misfit` (how thick the contacts' profile about an
  axis is: an accepted axis is polished where it is thinnest);
* metrics: :func:`surface_error` (-> :class:`SurfaceError`), :func:`shape_metrics`,
  :func:`symmetric_rmse_standard_error` (how much of an RMSE is the samples' own scatter),
  :func:`point_cloud_metrics` (-> :class:`ShapeMetrics`: Chamfer, F-score, normal consistency),
  :func:`contact_coverage`, :func:`recess_error` (-> :class:`RecessError`: the insides against the
  rest); :func:`surface_topology` (-> :class:`Topology`: parts, genus,
  boundary loops);
* test data: :func:`sample_contacts` with :class:`ContactNoise`; :func:`add_contact_noise` for
  contacts chosen elsewhere.

Every name is imported on first use (module ``__getattr__``), so ``import reconstruction`` does
not import torch.
"""
from __future__ import annotations

from common.lazy_exports import lazy_exports

_LAZY = {
    "GPIS": "reconstruction.gpis",
    "VarianceTracker": "reconstruction.gpis",
    "KERNEL_NAMES": "reconstruction.gpis",
    "ThinPlateKernel": "reconstruction.kernels",
    "ReferenceThinPlateKernel": "reconstruction.kernels",
    "SquaredExponentialKernel": "reconstruction.kernels",
    "QuadraticTrend": "reconstruction.kernels",
    "PartitionedGPIS": "reconstruction.partitioned_gpis",
    "mesh_zero_level": "reconstruction.meshing",
    "confident_surface": "reconstruction.confidence",
    "add_outside_evidence": "reconstruction.outside_evidence",
    "FacePlanes": "reconstruction.face_planes",
    "supporting_face_planes": "reconstruction.face_planes",
    "whole_face_planes": "reconstruction.face_planes",
    "ContactFaces": "reconstruction.face_planes",
    "supporting_contact_faces": "reconstruction.face_planes",
    "Symmetry": "reconstruction.symmetry",
    "SymmetrySettings": "reconstruction.symmetry",
    "find_symmetry": "reconstruction.symmetry",
    "contradicted_images": "reconstruction.symmetry",
    "disputed_contacts": "reconstruction.symmetry",
    "profile_misfit": "reconstruction.symmetry",
    "SurfaceError": "reconstruction.metrics",
    "Topology": "reconstruction.topology",
    "surface_topology": "reconstruction.topology",
    "ShapeMetrics": "reconstruction.metrics",
    "FSCORE_THRESHOLDS_M": "reconstruction.metrics",
    "surface_error": "reconstruction.metrics",
    "shape_metrics": "reconstruction.metrics",
    "symmetric_rmse_standard_error": "reconstruction.metrics",
    "point_cloud_metrics": "reconstruction.metrics",
    "contact_coverage": "reconstruction.metrics",
    "recess_error": "reconstruction.metrics",
    "RecessError": "reconstruction.metrics",
    "RECESS_DEPTH_M": "reconstruction.metrics",
    "ContactNoise": "reconstruction.synthetic_contacts",
    "sample_contacts": "reconstruction.synthetic_contacts",
    "add_contact_noise": "reconstruction.synthetic_contacts",
    "sphere_contacts": "reconstruction.synthetic_contacts",
}

__all__ = sorted(_LAZY)

__getattr__, __dir__ = lazy_exports(__name__, _LAZY)
