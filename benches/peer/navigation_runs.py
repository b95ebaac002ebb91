"""navigation.csv cut into runs where the world turns from frame to frame and where it
stands still; a still gap of under 6 frames inside motion counts as motion (a frame with
no new wand sample)."""
import csv, math, sys
rows = list(csv.DictReader(open(sys.argv[1])))
assert list(rows[0].keys()) == ["frame","time_ns","tx","ty","tz","qx","qy","qz","qw"], rows[0].keys()
yaw, prev = [], None
for r in rows:
    y = math.degrees(2 * math.atan2(float(r["qy"]), float(r["qw"])))
    if prev is not None:
        while y - prev > 180: y -= 360
        while y - prev < -180: y += 360
    yaw.append(y); prev = y
moving = [False] + [abs(yaw[i] - yaw[i-1]) > 1e-9 for i in range(1, len(rows))]
# fill still gaps under 6 frames that lie between moving frames
i = 0
while i < len(moving):
    if not moving[i]:
        j = i
        while j < len(moving) and not moving[j]: j += 1
        if 0 < i and j < len(moving) and j - i < 6:
            for k in range(i, j): moving[k] = True
        i = j
    else:
        i += 1
t = [int(r["time_ns"]) / 1e9 for r in rows]
start = 0
for i in range(1, len(rows) + 1):
    if i == len(rows) or moving[i] != moving[start]:
        a, b = start, i - 1
        dt = t[b] - t[max(a - 1, 0)] if moving[a] else t[b] - t[a]
        rate = (yaw[b] - yaw[max(a - 1, 0)]) / dt if dt > 0 else 0.0
        print(f"world {'moving' if moving[a] else 'still '}: frames {a:4d}-{b:4d}, t {t[a]:6.3f}-{t[b]:6.3f} s, "
              f"yaw {yaw[max(a-1,0)] if moving[a] else yaw[a]:9.3f} -> {yaw[b]:9.3f} deg ({rate:7.2f} deg/s)")
        start = i
same = len({(r["tx"], r["ty"], r["tz"]) for r in rows}) == 1
print(f"translation the same on every row: {same}")
