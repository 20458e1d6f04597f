; Seed 000 corner with Marlin input shaping: M593 before the first move (both axes ZV 40 Hz, zeta 0.05) and a change after it (not modelled: a warning).
G90
M593 F40 D0.05
G1 X0 Y0 F6000
G1 X10 Y0 F6000
M593 X F35
G1 X10 Y10 F6000
