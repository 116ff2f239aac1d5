//! Frame times and ray throughput: what the stats line and a session's summary
//! report.
//!
//! Rays are counted from the accumulation (its w), which costs a read-back, so the
//! viewer counts them now and then ([`RAY_COUNT_PERIOD`]) rather than every frame.
//! Mrays/s divides each count by the launch time of the launches that count covers
//! (not by the launch time up to the latest frame, nor by wall time with its waits
//! and display passes), so a count taken early stays right as frames go on.

use std::time::{Duration, Instant};

/// How often the viewer reads the accumulation back to count its rays.
pub const RAY_COUNT_PERIOD: Duration = Duration::from_millis(500);

/// Frame times and throughput.
#[derive(Clone, Debug, Default)]
pub struct Stats {
    /// Seconds between consecutive displayed frames.
    pub frame_times: Vec<f64>,
    /// Samples per pixel of each displayed frame.
    pub frame_samples: Vec<u32>,
    /// Seconds the launches since the accumulation last started over took (from
    /// submission to completion), as of the last displayed frame.
    pub launch_seconds: f64,
    /// The last ray count: rays in the accumulation then.
    pub counted_rays: u64,
    /// The launch seconds ([`Stats::launch_seconds`]) the last ray count covers.
    pub counted_seconds: f64,
    last_display: Option<Instant>,
}

impl Stats {
    /// Records a displayed frame of `samples` samples per pixel, displayed at
    /// `now`, whose launch took `launch`; `None` for a launch submitted before the
    /// last restart, whose time belongs to the accumulation that started over.
    pub fn frame(&mut self, samples: u32, launch: Option<Duration>, now: Instant) {
        if let Some(last) = self.last_display.replace(now) {
            self.frame_times.push((now - last).as_secs_f64());
        }
        self.frame_samples.push(samples);
        self.launch_seconds += launch.map_or(0.0, |t| t.as_secs_f64());
    }

    /// Records a count of the rays in the accumulation, taken after the last
    /// recorded frame: it covers the launch seconds recorded since the last restart.
    pub fn rays_counted(&mut self, rays: u64) {
        self.counted_rays = rays;
        self.counted_seconds = self.launch_seconds;
    }

    /// The accumulation started over: launch time counts from zero again. The last
    /// ray count stays what Mrays/s reports until the next count.
    pub fn restarted(&mut self) {
        self.launch_seconds = 0.0;
    }

    /// Millions of rays per second of launch time, from the last ray count.
    pub fn mrays_per_second(&self) -> f64 {
        if self.counted_seconds > 0.0 {
            self.counted_rays as f64 / self.counted_seconds / 1e6
        } else {
            0.0
        }
    }

    /// The median frame time in seconds over the last `n` frames.
    pub fn median_frame_time(&self, n: usize) -> Option<f64> {
        let mut last: Vec<f64> = self.frame_times.iter().rev().take(n).copied().collect();
        last.sort_by(f64::total_cmp);
        last.get(last.len() / 2).copied()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `n`/512 s: a whole number of nanoseconds and a binary fraction of a
    /// second, so the sums below are exact.
    fn ticks(n: u32) -> Duration {
        Duration::from_nanos(1_953_125 * u64::from(n))
    }

    #[test]
    fn mrays_per_second_divides_a_count_by_the_launch_time_it_covers() {
        let mut stats = Stats::default();
        let start = Instant::now();
        assert_eq!(stats.mrays_per_second(), 0.0, "nothing counted yet");
        // 120 frames of 3/512 s launches; the rays are counted after the first
        // one only (the viewer counts every RAY_COUNT_PERIOD), 1280×720×4 of them.
        stats.frame(1, Some(ticks(3)), start);
        stats.rays_counted(1280 * 720 * 4);
        for i in 1..120 {
            stats.frame(1, Some(ticks(3)), start + ticks(3) * i);
        }
        // The count covers the first launch alone: 3_686_400 rays / (3/512 s).
        assert_eq!(stats.counted_seconds, 3.0 / 512.0);
        assert_eq!(stats.mrays_per_second(), 3_686_400.0 / (3.0 / 512.0) / 1e6);
        assert!((stats.mrays_per_second() - 629.1456).abs() < 1e-9, "{}", stats.mrays_per_second());
        // A count after all 120 frames covers all 120 launches.
        stats.rays_counted(120 * 3_686_400);
        assert_eq!(stats.counted_seconds, 360.0 / 512.0);
        assert_eq!(stats.mrays_per_second(), 3_686_400.0 / (3.0 / 512.0) / 1e6);
        assert_eq!(stats.frame_times.len(), 119);
        assert_eq!(stats.median_frame_time(15), Some(3.0 / 512.0));
    }

    #[test]
    fn a_restart_keeps_the_last_count_until_the_next() {
        let mut stats = Stats::default();
        let start = Instant::now();
        stats.frame(2, Some(ticks(8)), start);
        stats.frame(2, Some(ticks(8)), start + ticks(10));
        stats.rays_counted(1 << 20);
        assert_eq!(stats.mrays_per_second(), (1u64 << 20) as f64 / (16.0 / 512.0) / 1e6);
        stats.restarted();
        assert_eq!(stats.launch_seconds, 0.0);
        assert_eq!(stats.mrays_per_second(), (1u64 << 20) as f64 / (16.0 / 512.0) / 1e6, "kept");
        // The launch in flight at the restart finishes: a frame, but no launch time.
        stats.frame(2, None, start + ticks(20));
        assert_eq!(stats.launch_seconds, 0.0);
        stats.frame(1, Some(ticks(2)), start + ticks(30));
        stats.rays_counted(1 << 10);
        assert_eq!(stats.counted_seconds, 2.0 / 512.0);
        assert_eq!(stats.mrays_per_second(), 1024.0 / (2.0 / 512.0) / 1e6);
        assert_eq!(stats.frame_samples, [2, 2, 2, 1]);
        assert_eq!(stats.frame_times, [10.0 / 512.0; 3]);
    }
}
