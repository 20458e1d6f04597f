; Klipper batch-mode reference input (see tests/reference/klipper/README.md)
SET_KINEMATIC_POSITION X=50 Y=50 Z=1
; ---- end preamble ----
G1 X70 Y50 F6000
G1 X70 Y70
G1 X50 Y70
G1 X50 Y50

