"""The worlds a controller pushes in, and what it sees of them: the model and MuJoCo plants, the
camera model, and the MuJoCo plant seen through rendered images."""
