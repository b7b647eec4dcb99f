// Thin-walled tray: a 60 x 40 x 25 mm open box with 0.6 mm walls and a 0.6 mm floor,
// three 0.4 mm ribs across it (15 mm high) and one 0.4 mm rib along it (10 mm high).
// Walls and ribs are 1.5 to 3 voxels thick at 256 voxels over 60 mm.
// Written for this repository, CC0.
L = 60; W = 40; H = 25;
t = 0.6;   // wall and floor
rib = 0.4;
union() {
    difference() {
        cube([L, W, H]);
        translate([t, t, t]) cube([L - 2 * t, W - 2 * t, H]);
    }
    // ribs reach into the floor and the walls so that they fuse with them
    for (x = [15, 30, 45]) translate([x - rib / 2, t / 2, t / 2]) cube([rib, W - t, 15]);
    translate([t / 2, W / 2 - rib / 2, t / 2]) cube([L - t, rib, 10]);
}
