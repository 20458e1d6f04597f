; Klipper batch-mode reference input for generic_cartesian (see README.md): XY moves, Z-only and
; XY+Z moves (max_z_velocity / max_z_accel scaled to the move), a retract, a slow Z hop.
SET_KINEMATIC_POSITION X=150 Y=100 Z=10
; ---- end preamble ----
G1 X250 Y100 F30000
G1 X250 Y180
G1 Z60 F6000
G1 X50 Y20 Z20 F30000
G1 E-1 F2400
G1 X150 Y100 Z10 F24000
G1 E1
G1 X200 Y120 E3 F3000
G1 X200 Y120 Z12 F600
G1 X10 Y190 Z11 F18000
G1 X290 Y5 F30000
