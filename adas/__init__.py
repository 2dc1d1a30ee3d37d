"""Generic driver-assistance controllers, driver models and the gymnasium environment."""
