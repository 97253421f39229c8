//! Scenes for decimation tests: four rooms in a 2 × 2 layout joined by door corridors
//! (the thesis's test case of 4.3 is four rooms joined by small corridors).

use super::scenes::Soup;

/// Room size and layout of [`four_rooms`].
pub const ROOM: f64 = 4.0;
/// Wall thickness between neighbouring rooms (the corridors' length).
pub const WALL: f64 = 1.0;
/// Room height.
pub const HEIGHT: f64 = 3.0;

/// Lower corner `(x, y)` of room `r` (0..4) of [`four_rooms`]: rooms 0, 1 on the bottom
/// row (`y ∈ [0, 4]`), 2, 3 on the top row (`y ∈ [5, 9]`); 0 and 2 on the left.
pub fn room_origin(r: usize) -> (f64, f64) {
    let step = ROOM + WALL;
    ((r % 2) as f64 * step, (r / 2) as f64 * step)
}

/// Four `4 × 4 × 3` rooms at `x, y ∈ {[0,4], [5,9]}`, walls facing in. With
/// `doors = [bottom, top, left, right]`: a door corridor (1 m wide, 2 m high, through the
/// 1 m wall) joins rooms 0–1 (`bottom`), 2–3 (`top`), 0–2 (`left`) and 1–3 (`right`).
/// Every door sits in the middle of its wall.
pub fn four_rooms_with(doors: [bool; 4]) -> Soup {
    let mut s = Soup::default();
    let step = ROOM + WALL;
    let half = 0.5;
    let door_h = 2.0;
    // Which walls of each room have a door: [x-, x+, y-, y+].
    let mut has = [[false; 4]; 4];
    if doors[0] {
        has[0][1] = true;
        has[1][0] = true;
    }
    if doors[1] {
        has[2][1] = true;
        has[3][0] = true;
    }
    if doors[2] {
        has[0][3] = true;
        has[2][2] = true;
    }
    if doors[3] {
        has[1][3] = true;
        has[3][2] = true;
    }
    for (r, walls) in has.iter().enumerate() {
        let (x0, y0) = room_origin(r);
        let (x1, y1) = (x0 + ROOM, y0 + ROOM);
        s.rect(2, 0.0, (x0, x1), (y0, y1), true);
        s.rect(2, HEIGHT, (x0, x1), (y0, y1), false);
        // axis, position, facing +axis, the horizontal span along the other axis.
        let list = [
            (0usize, x0, true, (y0, y1)),
            (0, x1, false, (y0, y1)),
            (1, y0, true, (x0, x1)),
            (1, y1, false, (x0, x1)),
        ];
        for (w, &(axis, at, facing, (h0, h1))) in list.iter().enumerate() {
            // rect's (u, v) are cyclic: for x walls u = y, v = z; for y walls u = z, v = x.
            let mut put = |h: (f64, f64), z: (f64, f64)| {
                if axis == 0 {
                    s.rect(0, at, h, z, facing);
                } else {
                    s.rect(1, at, z, h, facing);
                }
            };
            if walls[w] {
                let m = 0.5 * (h0 + h1);
                put((h0, m - half), (0.0, HEIGHT));
                put((m + half, h1), (0.0, HEIGHT));
                put((m - half, m + half), (door_h, HEIGHT));
            } else {
                put((h0, h1), (0.0, HEIGHT));
            }
        }
    }
    // Corridors: floor, ceiling and two sides, facing in.
    let mid = 0.5 * ROOM;
    if doors[0] || doors[1] {
        for (on, y) in [(doors[0], mid), (doors[1], step + mid)] {
            if !on {
                continue;
            }
            let (xa, xb) = (ROOM, step);
            s.rect(2, 0.0, (xa, xb), (y - half, y + half), true);
            s.rect(2, door_h, (xa, xb), (y - half, y + half), false);
            s.rect(1, y - half, (0.0, door_h), (xa, xb), true);
            s.rect(1, y + half, (0.0, door_h), (xa, xb), false);
        }
    }
    for (on, x) in [(doors[2], mid), (doors[3], step + mid)] {
        if !on {
            continue;
        }
        let (ya, yb) = (ROOM, step);
        s.rect(2, 0.0, (x - half, x + half), (ya, yb), true);
        s.rect(2, door_h, (x - half, x + half), (ya, yb), false);
        s.rect(0, x - half, (ya, yb), (0.0, door_h), true);
        s.rect(0, x + half, (ya, yb), (0.0, door_h), false);
    }
    s
}

/// [`four_rooms_with`] with all four doors (a ring of rooms).
pub fn four_rooms() -> Soup {
    four_rooms_with([true; 4])
}

/// Sample points well inside room `r` (0..4) of [`four_rooms`]: a 3 × 3 × 2 grid inset
/// 0.5 m from the walls.
pub fn room_samples(r: usize) -> Vec<[f64; 3]> {
    let (x0, y0) = room_origin(r);
    let mut v = Vec::new();
    for i in 0..3 {
        for j in 0..3 {
            for k in 0..2 {
                v.push([
                    x0 + 0.5 + 1.5 * i as f64,
                    y0 + 0.5 + 1.5 * j as f64,
                    0.5 + 2.0 * k as f64,
                ]);
            }
        }
    }
    v
}
