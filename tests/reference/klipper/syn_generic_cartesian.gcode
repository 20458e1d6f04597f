; Klipper batch-mode reference input for generic_cartesian (see README.md): XY moves, Z-only and
; XY+Z moves (max_z_velocity / max_z_accel scaled to the move), retracts, a slow Z hop. (A
; retract early on: stock batch mode fully flushes its queue about 2 s into a file, which
; stops the toolhead unless it is stopped there anyway; see README.md.)
SET_KINEMATIC_POSITION X=150 Y=100 Z=10
; ---- end preamble ----
G1 X250 Y100 F30000
G1 E-1 F2400
G1 X250 Y180 F30000
G1 E1 F2400
G1 Z30 F6000
G1 X50 Y20 Z20 F30000
G1 E-1 F2400
G1 X150 Y100 Z10 F24000
G1 E1
G1 X200 Y120 E3 F3000
G1 X200 Y120 Z12 F600
G1 X10 Y190 Z11 F18000
G1 X290 Y5 F30000
