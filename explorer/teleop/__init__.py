"""Human-guided exploration: input devices and the teleoperated session (shared autonomy)."""
