"""The grains: release, motion with drag, the bed and its splash, the exchange with the air, and the impact record."""
