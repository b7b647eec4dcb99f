// Nearly coplanar faces: a 60 x 60 x 20 mm block whose top is nine 20 x 20 mm patches,
// each raised 0 to 0.01 mm above z = 20 (steps of 0.001 mm between some neighbours) and
// tilted 0 to 0.1 degrees from horizontal (0.1 degree rises 0.035 mm over 20 mm). The
// centre patch is flat at z = 20. Beside it a 10 x 10 mm pocket has its floor at
// z = 19.995, 0.005 mm below the centre flat; in the back middle patch a 12 x 12 mm,
// 5 mm deep pocket has a 4 mm shelf 0.005 mm above its floor.
// Written for this repository, CC0.
s = 20;     // patch size
top = 20;   // nominal top
// [column, row, raise, tilt (degrees), tilt direction (degrees)]
patches = [
    [0, 0, 0.010, 0.05,   0], [1, 0, 0.001, 0,    0], [2, 0, 0.005, 0.1,   90],
    [0, 1, 0.002, 0.01,  45], [1, 1, 0,     0,    0], [2, 1, 0.003, 0.02, 180],
    [0, 2, 0.008, 0.1,  270], [1, 2, 0.004, 0.03, 135], [2, 2, 0.006, 0.07, 300],
];
// A square prism from z = top - 1 up to a tilted plane through (centre, top + raise).
module patch(i, j, raise, tilt, dir) {
    x0 = i * s; y0 = j * s;
    cx = x0 + s / 2; cy = y0 + s / 2;
    function z(x, y) = top + raise + tan(tilt) * ((x - cx) * cos(dir) + (y - cy) * sin(dir));
    c = [[x0, y0], [x0 + s, y0], [x0 + s, y0 + s], [x0, y0 + s]];
    polyhedron(
        points = concat([for (p = c) [p[0], p[1], top - 1]],
                        [for (p = c) [p[0], p[1], z(p[0], p[1])]]),
        faces = [[0, 1, 2, 3], [4, 7, 6], [4, 6, 5],
                 [0, 4, 5, 1], [1, 5, 6, 2], [2, 6, 7, 3], [3, 7, 4, 0]]);
}
difference() {
    union() {
        cube([3 * s, 3 * s, top - 0.5]);
        for (p = patches) patch(p[0], p[1], p[2], p[3], p[4]);
    }
    // shallow pocket in the right middle patch, floor 0.005 mm below the centre flat
    translate([45, 25, top - 0.005]) cube([10, 10, 1]);
    // deep pocket in the back middle patch: floor at z = 15, shelf at z = 15.005
    translate([24, 44, top - 5 + 0.005]) cube([12, 12, 6]);
    translate([28, 44, top - 5]) cube([8, 12, 6]);
}
