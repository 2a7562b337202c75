"""rclpy.timer: ``Timer`` and ``Rate`` (created by ``Node.create_timer`` / ``Node.create_rate``)."""

from rclpy._entities import Rate, Timer

__all__ = ["Rate", "Timer"]
