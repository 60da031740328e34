"""emulator: the time of robot-skin fieldbus frames (cycle-time model and virtual daisy chain)."""
