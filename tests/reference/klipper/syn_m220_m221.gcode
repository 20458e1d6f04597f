; Klipper batch-mode reference input (see tests/reference/klipper/README.md)
SET_KINEMATIC_POSITION X=50 Y=50 Z=1
; ---- end preamble ----
M83
G1 X70 E1.0 F3000
M220 S50
G1 Y70 E1.0
M221 S90
G1 X50 E1.0
M220 S150
G1 Y50 E1.0
M220 S100
M221 S100
G1 X70 E1.0

