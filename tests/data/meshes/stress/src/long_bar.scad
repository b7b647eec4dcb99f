// A 200 x 2 x 2 mm bar along X (100 times longer than thick) with three 1 mm wide,
// 0.5 mm deep notches in the top, one 0.8 mm deep notch in the side and a 0.7 mm deep
// 90-degree V-notch underneath. Written for this repository, CC0.
difference() {
    cube([200, 2, 2]);
    for (x = [40, 100, 160]) translate([x - 0.5, -1, 1.5]) cube([1, 4, 1]);
    translate([69.5, -1, -1]) cube([1, 1.8, 4]);
    translate([130, 1, 0]) rotate([0, 45, 0]) cube([1, 4, 1], center = true);
}
