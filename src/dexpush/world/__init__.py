"""The worlds a controller pushes in, and what it sees of them: the model and MuJoCo plants and
the camera model."""
