; Seed 000 base path (table 3.2): 10 mm along X, then 10 mm along Y, at 100 mm/s.
G90
G1 X0 Y0 F6000
G1 X10 Y0 F6000
G1 X10 Y10 F6000
