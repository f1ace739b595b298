"""Pure physical laws: threshold, drag, splash, soil size distribution, semi-empirical laws."""
