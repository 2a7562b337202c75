# One image for every node of the main job; docker-compose.yml picks each container's command.
#   docker build -t zenroid .      (docker-compose builds it for you)
FROM python:3.11-slim-bookworm

# dartpy's wheel links libGL/libX11 (no display is ever opened); the Rerun server binary links libudev.
RUN apt-get update \
    && apt-get install -y --no-install-recommends libgl1 libudev1 \
    && rm -rf /var/lib/apt/lists/*

WORKDIR /app
COPY . /app
RUN pip install --no-cache-dir /app

# The commands use paths relative to /app (robots/humanoid.urdf, config/controllers.yaml).
ENV PYTHONUNBUFFERED=1
CMD ["zenroid", "doctor"]
