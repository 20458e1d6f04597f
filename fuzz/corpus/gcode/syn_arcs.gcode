; Klipper batch-mode reference input (see tests/reference/klipper/README.md)
SET_KINEMATIC_POSITION X=50 Y=50 Z=1
; ---- end preamble ----
G17
M83
G2 X100 Y50 I25 J0 F6000
G3 X150 Y50 I25 J0 E2.0
G2 X150 Y50 I-20 J0 F3000
G3 X130 Y70 I-20 J0 F6000
G1 X100 Y70

