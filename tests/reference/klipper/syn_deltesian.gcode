; Klipper batch-mode reference input for the deltesian (see README.md): moves inside
; |x| < 45.86 mm (Klipper's slow zones are not entered: see docs/machine.md, "Deltesian"),
; Y moves, Z moves at max_z_velocity, a climb to z = 200.
SET_KINEMATIC_POSITION X=0 Y=100 Z=10
; ---- end preamble ----
G1 X40 Y100 F24000
G1 X40 Y180
G1 X-40 Y20 Z12
G1 Y100 Z60 F18000
G1 X0 Y150 Z200
G1 X30 Z10 F12000
G1 E-1 F2400
G1 X-30 Y40 F30000
G1 E1
G1 X20 Y60 E3 F3000
