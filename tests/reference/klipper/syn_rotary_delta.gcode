; Klipper batch-mode reference input for rotary_delta (see README.md): XY moves, a Z-only and an
; XY+Z move (capped at max_z_velocity 50 mm/s, not scaled to the move), a retract, moves far out.
SET_KINEMATIC_POSITION X=0 Y=0 Z=10
; ---- end preamble ----
G1 X100 Y0 F18000
G1 X100 Y100
G1 Z60 F18000
G1 X-100 Y-50 Z20
G1 E-1 F2400
G1 X0 Y0 Z10 F24000
G1 E1
G1 X50 Y20 E3 F3000
G1 X-150 Y0 F30000
G1 X0 Y150 Z10.2
G1 X0 Y-150 Z10
