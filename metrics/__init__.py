"""Error metrics on arrays (pure numpy; imports neither renderer).

Intersection error by layer count, interaction (bounce) depth, binary-search
iterations and peak samples; path metrics; image error per component; noise
statistics (z-tests against references with per-pixel variance).
"""
