// Turned shaft, 80 mm long along Z: a 20 mm journal with a 1 mm chamfer at the bottom
// and a 2 x 1.2 mm groove, a shoulder (0.5 mm chamfer) up to 28 mm, a 2.5 x 1.5 mm
// groove, a 30-degree 2 mm chamfer and a 60-degree centre drill at the top, and a 6 mm
// cross hole through the 28 mm section. rotate_extrude of one profile, $fn = 128.
// Written for this repository, CC0.
$fn = 128;
// (radius, z), counter-clockwise in the XZ half plane
profile = [
    [0, 0], [9, 0], [10, 1],                        // bottom face and 1 x 45 chamfer
    [10, 10], [8.8, 10], [8.8, 12], [10, 12],       // groove 1 in the 20 mm journal
    [10, 30], [13.5, 30], [14, 30.5],               // shoulder with a 0.5 mm chamfer
    [14, 52], [12.5, 52], [12.5, 54.5], [14, 54.5], // groove 2 in the 28 mm section
    [14, 78], [12.845, 80],                         // 30-degree chamfer, 2 mm long
    [2, 80], [0, 80 - 2 / tan(30)]                  // 60-degree centre drill, 4 mm
];
difference() {
    rotate_extrude() polygon(profile);
    translate([-20, 0, 65]) rotate([0, 90, 0]) cylinder(d = 6, h = 40);
}
