"""rclpy's logger services (ROS 2 Iron+) for one node: ``zenroid log level NODE debug`` changes the level of
a running node."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from msgs.rcl_interfaces import GetLoggerLevels, LoggerLevel, SetLoggerLevels, SetLoggerLevelsResult
from nodes.core.log import Logger, parse_level


class LoggerLevelServices:
    def __init__(self, logger: Logger, aliases: tuple[str, ...]) -> None:
        """``aliases``: the other names a request may use for this node's logger (its name, its full name)."""
        self.logger = logger
        self.aliases = aliases

    def serve(self, create_service: Callable[..., Any]) -> None:
        create_service(GetLoggerLevels, "~/get_logger_levels", self._srv_get)
        create_service(SetLoggerLevels, "~/set_logger_levels", self._srv_set)

    def _srv_get(self, request: Any) -> Any:
        names = request.names or [self.logger.name]
        return GetLoggerLevels.Response(levels=[
            LoggerLevel(name=n, level=self.logger.level if n == self.logger.name else 0) for n in names])

    def _srv_set(self, request: Any) -> Any:
        results = []
        for item in request.levels:
            if item.name != self.logger.name and item.name not in self.aliases:
                results.append(SetLoggerLevelsResult(successful=False, reason=f"no logger '{item.name}' in this "
                                                      f"node (its logger is '{self.logger.name}')"))
                continue
            try:
                self.logger.set_level(parse_level(int(item.level)))
            except ValueError as exc:
                results.append(SetLoggerLevelsResult(successful=False, reason=str(exc)))
                continue
            self.logger.info(f"log level set to {self.logger.level_name}")
            results.append(SetLoggerLevelsResult(successful=True))
        return SetLoggerLevels.Response(results=results)
