"""Capture grass blades from a depth camera, OpenNI2 recordings or depth images."""
