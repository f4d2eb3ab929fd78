"""Poses from camera images: calibrated cameras, ArUco markers, table-plane poses, fusion, live sources.

The geometry (``camera_model``, ``camera_file``, ``markers``, ``planar_pose``) is numpy only; detection
and calibration need OpenCV (``pip install 'dexpush[camera]'``), imported on use. See docs/perception.md.
"""
