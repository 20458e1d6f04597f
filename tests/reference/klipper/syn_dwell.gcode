; Klipper batch-mode reference input (see tests/reference/klipper/README.md)
SET_KINEMATIC_POSITION X=50 Y=50 Z=1
; ---- end preamble ----
G1 X60 F6000
G4 P500
G1 Y60
G4 P500
G1 X50
G1 Y50

