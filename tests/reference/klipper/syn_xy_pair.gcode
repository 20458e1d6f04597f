; Klipper batch-mode reference input (see tests/reference/klipper/README.md)
SET_KINEMATIC_POSITION X=50 Y=50 Z=1
; ---- end preamble ----
M204 S5000
G1 X60 F6000
G1 Y60 F6000

