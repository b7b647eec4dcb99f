// A 100 mm cube with rounded edges and corners and dice pips (spherical dimples) in every
// face, about 12,000 facets (issue 32's hang 2). Written for this repository, CC0.
$fn = 32;
r = 10;
s = 100;
pip = 8;
module rounded_cube() {
    hull() for (x = [-1, 1], y = [-1, 1], z = [-1, 1])
        translate([x, y, z] * (s / 2 - r)) sphere(r);
}
// Pip centres of face n (1..6) in the face plane, offsets in units of 25 mm.
function pips(n) =
    n == 1 ? [[0, 0]] :
    n == 2 ? [[-1, -1], [1, 1]] :
    n == 3 ? [[-1, -1], [0, 0], [1, 1]] :
    n == 4 ? [[-1, -1], [-1, 1], [1, -1], [1, 1]] :
    n == 5 ? [[-1, -1], [-1, 1], [0, 0], [1, -1], [1, 1]] :
             [[-1, -1], [-1, 0], [-1, 1], [1, -1], [1, 0], [1, 1]];
faces = [[0, 0, 0], [90, 0, 0], [0, 90, 0], [0, -90, 0], [-90, 0, 0], [180, 0, 0]];
difference() {
    rounded_cube();
    for (f = [0 : 5]) rotate(faces[f])
        for (p = pips(f + 1)) translate([p[0] * 25, p[1] * 25, s / 2 + pip * 0.4]) sphere(pip);
}
