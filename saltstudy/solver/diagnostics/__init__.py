"""Read-only measurements of a running model (profiles, the grains' sums, field health); nothing here changes the state."""
