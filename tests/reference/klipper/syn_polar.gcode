; Klipper batch-mode reference input for polar (see README.md): moves far from and close to
; the bed's centre (max_angular_velocity 5 rad/s slows them), Z-only and XY+Z moves (max_z_velocity
; / max_z_accel scaled to the move), a retract, a move ending at the edge of the arm's reach.
SET_KINEMATIC_POSITION X=100 Y=0 Z=10
; ---- end preamble ----
G1 X100 Y100 F18000
G1 X-100 Y5
G1 X100 Y-6
G1 X20 Y20 F6000
G1 X-20 Y20
G1 X-1 Y-50 Z20 F12000
G1 Z30 F3000
G1 X2 Y50 F9000
G1 E-1 F2400
G1 X150 Y-150 F30000
G1 E1
G1 X140 Y-140 E2 F3000
G1 X2 Y1 F9000
G1 X2 Y-1
G1 X-2 Y-1
G1 X300 Y0 F30000
G1 X0 Y300
