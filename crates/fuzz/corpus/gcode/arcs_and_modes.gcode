; a hand-written job: inches, relative moves, arcs, Z pen and spindle pen
G20 G90 G17
G0 X0 Y0 Z1
M3 S1000
G1 Z-0.1 F20
G1 X1 Y0
G2 X2 Y1 I0 J1
G3 X1 Y2 R1
G91
G1 X-0.5 Y-0.5 ; relative
G90 G21
G1 X10.5 Y-3.25 F600
M5
(done) G0 X0 Y0
$H
