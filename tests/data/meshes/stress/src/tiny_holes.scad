// A 50 x 50 x 10 mm plate with a 7 x 7 grid of through holes, 0.2 to 0.5 mm across
// (one diameter per column, 5 mm pitch), and two rows of blind holes 0.3 to 1 mm across,
// 3 mm deep from the top and 2 mm deep from the bottom. At 256 voxels over 50 mm a voxel
// is about 0.2 mm, so the through holes are 1 to 2.5 voxels wide. $fn = 24.
// Written for this repository, CC0.
$fn = 24;
through = [0.2, 0.25, 0.3, 0.35, 0.4, 0.45, 0.5];
blind = [0.3, 0.4, 0.5, 0.6, 0.8, 1.0];
difference() {
    cube([50, 50, 10]);
    for (i = [0 : 6], j = [0 : 6])
        translate([10 + 5 * i, 10 + 5 * j, -1]) cylinder(d = through[i], h = 12);
    for (i = [0 : 5]) {
        translate([7.5 + 7 * i, 45.5, 7]) cylinder(d = blind[i], h = 4);   // from the top
        translate([7.5 + 7 * i, 4.5, -1]) cylinder(d = blind[i], h = 3);   // from the bottom
    }
}
