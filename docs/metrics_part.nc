(contour-gym docs: a W engraved with sharp turns, 157 degrees each)
G21 G90 G17
G0 X0 Y20
G1 F1200 X4 Y0
X8 Y20
X12 Y0
X16 Y20
M2
