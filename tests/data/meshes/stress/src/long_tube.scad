// A tube along X, 150 mm long, 3 mm outer and 1.5 mm inner diameter (0.75 mm wall,
// 50 times longer than wide), $fn = 48. Written for this repository, CC0.
$fn = 48;
rotate([0, 90, 0]) difference() {
    cylinder(d = 3, h = 150);
    translate([0, 0, -1]) cylinder(d = 1.5, h = 152);
}
