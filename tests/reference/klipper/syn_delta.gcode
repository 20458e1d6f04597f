; Klipper batch-mode reference input for the delta (see README.md): moves inside the free
; zone, into the half-speed ring (r > 141.2 mm) and the quarter-speed ring (r > 153.7 mm),
; Z moves limited by max_z_velocity/max_z_accel, and a climb above the cone start.
SET_KINEMATIC_POSITION X=0 Y=0 Z=10
; ---- end preamble ----
G1 X50 Y0 F18000
G1 X50 Y50
G1 X-50 Y50
G1 X0 Y-60 Z12
G1 X0 Y-145 F15000
G1 X100 Y-100
G1 X150 Y0
G1 X120 Y80 Z20
G1 X0 Y155 F12000
G1 X-100 Y100
G1 X-120 Y-60 Z5 F9000
G1 X-30 Y-30 F20000
G1 Z40 F9000
G1 X30 Y30 Z150 F30000
G1 X0 Y0 Z250
G1 X20 Y0 Z280
G1 X0 Y0 Z10 F6000
G1 X10 Y10 E2 F3000
G1 E-1 F2400
G1 E1
G1 X140 Y-20 E10 F6000
G1 X-140 Y20 F24000
