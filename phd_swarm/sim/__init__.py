"""The simulated world: targets, robot kinematics, the sensor. Seeded numpy Generators only."""
