"""Navigation: Earth model, rotation schedules, trajectories, ideal IMU, strapdown, alignment."""
